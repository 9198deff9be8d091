// GET /: the landing page (render/web/home.html: upload a folder or an archive, choose a model,
// follow the job, open the viewer); GET /api/v1/models: the models a fit job accepts.
#include "fit/method.h"
#include "server/server_impl.h"
#include "server/web_assets.h"

namespace matfit::server {

using json = nlohmann::json;

void Server::Impl::RegisterHomeRoutes() {
  http.Get("/", [](const httplib::Request&, httplib::Response& res) {
    res.set_content(std::string(WebAsset("home.html")), "text/html; charset=utf-8");
  });
  http.Get("/api/v1/models", [](const httplib::Request&, httplib::Response& res) {
    json models = json::array();
    // "views": what a job's view field must be for the model (one view, or all of a BTF).
    for (const auto& [list, views] :
         {std::pair{fit::MethodNames(), "one"}, std::pair{fit::MultiViewMethodNames(), "all"},
          std::pair{fit::PerViewMethodNames(), "all"}})
      for (const auto& name : list) {
        const auto m = fit::MakeMethod(name);
        models.push_back({{"name", name},
                          {"description", m ? m->description() : ""},
                          {"bytes_per_texel", m ? m->bytes_per_texel() : 0},
                          {"views", views}});
      }
    SendJson(res, 200,
             {{"models", models},
              {"default", "auto"},
              {"auto",
               "the simplest model whose held-out error the data support "
               "(docs/selection.md)"},
              {"modes", {"fit", "leaf"}}});
  });
}

}  // namespace matfit::server
