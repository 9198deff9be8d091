#include "render/egl_renderer.h"

#define EGL_EGLEXT_PROTOTYPES
#include <EGL/egl.h>
#include <EGL/eglext.h>
#include <GLES3/gl32.h>

#include <cstring>
#include <vector>

#include "core/pack/shader_params.h"
#include "render/shader_sources.h"

namespace matfit::render {

struct EglRenderer::State {
  EGLDisplay display = EGL_NO_DISPLAY;
  EGLContext context = EGL_NO_CONTEXT;
  GLuint program = 0, vao = 0;
  std::string description;
};

namespace {

Status Internal(std::string m) { return {StatusCode::kInternal, std::move(m)}; }

std::string EglErrorName(EGLint e) {
  switch (e) {
    case EGL_NOT_INITIALIZED: return "EGL_NOT_INITIALIZED";
    case EGL_BAD_DISPLAY: return "EGL_BAD_DISPLAY";
    case EGL_BAD_CONFIG: return "EGL_BAD_CONFIG";
    case EGL_BAD_MATCH: return "EGL_BAD_MATCH";
    case EGL_BAD_ATTRIBUTE: return "EGL_BAD_ATTRIBUTE";
    case EGL_BAD_ALLOC: return "EGL_BAD_ALLOC";
    default: return "EGL error " + std::to_string(e);
  }
}

Status Unavailable(const std::string& what) {
  return Status(StatusCode::kUnavailable,
                "EGL renderer unavailable: " + what +
                    " (needs Mesa's EGL with EGL_MESA_platform_surfaceless, or a GPU driver; "
                    "use --backend cpu)");
}

StatusOr<GLuint> Compile(GLenum type, const std::string& src, const char* name) {
  const GLuint sh = glCreateShader(type);
  const char* text = src.c_str();
  glShaderSource(sh, 1, &text, nullptr);
  glCompileShader(sh);
  GLint ok = 0;
  glGetShaderiv(sh, GL_COMPILE_STATUS, &ok);
  if (!ok) {
    char log[4096] = {};
    glGetShaderInfoLog(sh, sizeof log - 1, nullptr, log);
    glDeleteShader(sh);
    return Internal(std::string("shader ") + name + " does not compile: " + log);
  }
  return sh;
}

}  // namespace

EglRenderer::EglRenderer(std::unique_ptr<State> s) : s_(std::move(s)) {}

EglRenderer::~EglRenderer() {
  if (!s_) return;
  if (s_->context != EGL_NO_CONTEXT) {
    eglMakeCurrent(s_->display, EGL_NO_SURFACE, EGL_NO_SURFACE, s_->context);
    if (s_->program) glDeleteProgram(s_->program);
    if (s_->vao) glDeleteVertexArrays(1, &s_->vao);
    eglMakeCurrent(s_->display, EGL_NO_SURFACE, EGL_NO_SURFACE, EGL_NO_CONTEXT);
    eglDestroyContext(s_->display, s_->context);
  }
  if (s_->display != EGL_NO_DISPLAY) eglTerminate(s_->display);
}

StatusOr<std::unique_ptr<EglRenderer>> EglRenderer::Create() {
  auto s = std::make_unique<State>();
  const char* client = eglQueryString(EGL_NO_DISPLAY, EGL_EXTENSIONS);
  if (!client || !std::strstr(client, "EGL_MESA_platform_surfaceless"))
    return Unavailable("no EGL client extension EGL_MESA_platform_surfaceless");
  s->display = eglGetPlatformDisplay(EGL_PLATFORM_SURFACELESS_MESA, EGL_DEFAULT_DISPLAY, nullptr);
  EGLint major = 0, minor = 0;
  if (s->display == EGL_NO_DISPLAY || !eglInitialize(s->display, &major, &minor))
    return Unavailable("eglInitialize failed (" + EglErrorName(eglGetError()) + ")");
  if (!eglBindAPI(EGL_OPENGL_ES_API)) return Unavailable("eglBindAPI(EGL_OPENGL_ES_API) failed");
  // Surfaceless Mesa may flag its configs ES2-only though they run ES 3 contexts; without any
  // config, EGL_KHR_no_config_context still allows a context.
  EGLConfig config = EGL_NO_CONFIG_KHR;
  EGLint configs = 0;
  for (EGLint bit : {EGLint(EGL_OPENGL_ES3_BIT), EGLint(EGL_OPENGL_ES2_BIT)}) {
    const EGLint config_attrs[] = {EGL_RENDERABLE_TYPE, bit, EGL_SURFACE_TYPE, EGL_DONT_CARE,
                                   EGL_NONE};
    if (eglChooseConfig(s->display, config_attrs, &config, 1, &configs) && configs > 0) break;
    config = EGL_NO_CONFIG_KHR;
  }
  for (EGLint minor_version : {2, 0}) {
    const EGLint ctx_attrs[] = {EGL_CONTEXT_MAJOR_VERSION, 3, EGL_CONTEXT_MINOR_VERSION,
                                minor_version, EGL_NONE};
    s->context = eglCreateContext(s->display, config, EGL_NO_CONTEXT, ctx_attrs);
    if (s->context != EGL_NO_CONTEXT) break;
  }
  if (s->context == EGL_NO_CONTEXT)
    return Unavailable(std::string("no OpenGL ES 3 context") +
                       (config == EGL_NO_CONFIG_KHR ? " (no EGL config either)" : "") + " (" +
                       EglErrorName(eglGetError()) + ")");
  if (!eglMakeCurrent(s->display, EGL_NO_SURFACE, EGL_NO_SURFACE, s->context))
    return Unavailable("surfaceless eglMakeCurrent failed (" + EglErrorName(eglGetError()) + ")");
  const char* exts = reinterpret_cast<const char*>(glGetString(GL_EXTENSIONS));
  const char* version = reinterpret_cast<const char*>(glGetString(GL_VERSION));
  const char* renderer = reinterpret_cast<const char*>(glGetString(GL_RENDERER));
  s->description = std::string(version ? version : "?") + ", " + (renderer ? renderer : "?");
  if (!(version && std::strstr(version, "OpenGL ES 3.2")) &&
      !(exts && std::strstr(exts, "GL_EXT_color_buffer_float")))
    return Unavailable("the context cannot render to float framebuffers (" + s->description + ")");
  auto vs = Compile(GL_VERTEX_SHADER, FullscreenVertexShader(), "fullscreen.vert");
  if (!vs.ok()) return vs.status();
  auto fs = Compile(GL_FRAGMENT_SHADER, MaterialFragmentShader(), "material.frag");
  if (!fs.ok()) return fs.status();
  s->program = glCreateProgram();
  glAttachShader(s->program, *vs);
  glAttachShader(s->program, *fs);
  glLinkProgram(s->program);
  glDeleteShader(*vs);
  glDeleteShader(*fs);
  GLint linked = 0;
  glGetProgramiv(s->program, GL_LINK_STATUS, &linked);
  if (!linked) {
    char log[4096] = {};
    glGetProgramInfoLog(s->program, sizeof log - 1, nullptr, log);
    return Internal(std::string("shader program does not link: ") + log);
  }
  glGenVertexArrays(1, &s->vao);
  return std::unique_ptr<EglRenderer>(new EglRenderer(std::move(s)));
}

std::string EglRenderer::Description() const { return s_->description; }

StatusOr<Image> EglRenderer::Render(const MaterialMaps& maps, const RenderOptions& o) {
  std::string why;
  if (!o.Check(&why)) return InvalidArgument(why);
  auto g = PackShaderParams(maps);
  if (!g.ok()) return g.status();
  GLint max_size = 0, max_layers = 0;
  glGetIntegerv(GL_MAX_TEXTURE_SIZE, &max_size);
  glGetIntegerv(GL_MAX_ARRAY_TEXTURE_LAYERS, &max_layers);
  if (g->width > max_size || g->height > max_size || o.size > max_size || g->layers > max_layers)
    return InvalidArgument("material " + std::to_string(g->width) + " × " +
                           std::to_string(g->height) + " or output size " + std::to_string(o.size) +
                           " exceeds the GPU limit of " + std::to_string(max_size));
  eglMakeCurrent(s_->display, EGL_NO_SURFACE, EGL_NO_SURFACE, s_->context);
  GLuint tex = 0, fbo = 0, rb = 0;
  glGenTextures(1, &tex);
  glBindTexture(GL_TEXTURE_2D_ARRAY, tex);
  glTexParameteri(GL_TEXTURE_2D_ARRAY, GL_TEXTURE_MIN_FILTER, GL_NEAREST);
  glTexParameteri(GL_TEXTURE_2D_ARRAY, GL_TEXTURE_MAG_FILTER, GL_NEAREST);
  glPixelStorei(GL_UNPACK_ALIGNMENT, 4);
  glTexImage3D(GL_TEXTURE_2D_ARRAY, 0, GL_RGBA32F, g->width, g->height, g->layers, 0, GL_RGBA,
               GL_FLOAT, g->texels.data());
  // rbf: the basis table as a second array texture (one R32F layer per term) on unit 1.
  GLuint table = 0;
  if (g->table_size > 0) {
    glGenTextures(1, &table);
    glBindTexture(GL_TEXTURE_2D_ARRAY, table);
    glTexParameteri(GL_TEXTURE_2D_ARRAY, GL_TEXTURE_MIN_FILTER, GL_NEAREST);
    glTexParameteri(GL_TEXTURE_2D_ARRAY, GL_TEXTURE_MAG_FILTER, GL_NEAREST);
    glTexImage3D(GL_TEXTURE_2D_ARRAY, 0, GL_R32F, g->table_size, g->table_size, g->terms, 0, GL_RED,
                 GL_FLOAT, g->basis_table.data());
  }
  glGenRenderbuffers(1, &rb);
  glBindRenderbuffer(GL_RENDERBUFFER, rb);
  glRenderbufferStorage(GL_RENDERBUFFER, GL_RGBA32F, o.size, o.size);
  glGenFramebuffers(1, &fbo);
  glBindFramebuffer(GL_FRAMEBUFFER, fbo);
  glFramebufferRenderbuffer(GL_FRAMEBUFFER, GL_COLOR_ATTACHMENT0, GL_RENDERBUFFER, rb);
  Status status;
  if (glCheckFramebufferStatus(GL_FRAMEBUFFER) != GL_FRAMEBUFFER_COMPLETE) {
    status = Internal("RGBA32F framebuffer incomplete on " + s_->description);
  } else {
    glViewport(0, 0, o.size, o.size);
    glUseProgram(s_->program);
    const GLuint p = s_->program;
    const Vec3 l = o.LightDirection();
    const Vec3 rad = o.light_color * o.intensity;
    glUniform1i(glGetUniformLocation(p, "u_params"), 0);
    glUniform1i(glGetUniformLocation(p, "u_basis_table"), 1);
    glUniform1i(glGetUniformLocation(p, "u_table_size"), g->table_size);
    glUniform2i(glGetUniformLocation(p, "u_texels"), g->width, g->height);
    glUniform1i(glGetUniformLocation(p, "u_size"), o.size);
    glUniform1i(glGetUniformLocation(p, "u_scene"), int(o.scene));
    glUniform1i(glGetUniformLocation(p, "u_model"), g->model);
    glUniform1i(glGetUniformLocation(p, "u_terms"), g->terms);
    glUniform1i(glGetUniformLocation(p, "u_coef_channels"), g->coef_channels);
    glUniform1i(glGetUniformLocation(p, "u_basis_srgb"), g->basis_srgb);
    glUniform1i(glGetUniformLocation(p, "u_heinrich_specular"), g->heinrich_specular);
    glUniform1i(glGetUniformLocation(p, "u_flat_normal"), g->flat_normal);
    glUniform1i(glGetUniformLocation(p, "u_leaf_base"), g->leaf_base);
    glUniform1i(glGetUniformLocation(p, "u_leaf_hl2"), g->leaf_hl2);
    glUniform3f(glGetUniformLocation(p, "u_light"), float(l.x), float(l.y), float(l.z));
    const CameraFrame cam = MakeCamera(o.camera_theta_deg, o.camera_phi_deg);
    glUniform3f(glGetUniformLocation(p, "u_cam_v"), cam.v.x, cam.v.y, cam.v.z);
    glUniform3f(glGetUniformLocation(p, "u_cam_r"), cam.r.x, cam.r.y, cam.r.z);
    glUniform3f(glGetUniformLocation(p, "u_cam_u"), cam.u.x, cam.u.y, cam.u.z);
    glUniform3f(glGetUniformLocation(p, "u_intensity"), float(rad.x), float(rad.y), float(rad.z));
    const float a = float(o.ambient);
    glUniform3f(glGetUniformLocation(p, "u_ambient"), a, a, a);
    glUniform1f(glGetUniformLocation(p, "u_exposure"), float(o.exposure));
    glUniform1i(glGetUniformLocation(p, "u_tonemap"), int(o.tonemap));
    glUniform1i(glGetUniformLocation(p, "u_display"), o.display);
    glActiveTexture(GL_TEXTURE1);
    glBindTexture(GL_TEXTURE_2D_ARRAY, table);
    glActiveTexture(GL_TEXTURE0);
    glBindTexture(GL_TEXTURE_2D_ARRAY, tex);
    glBindVertexArray(s_->vao);
    glClearColor(0, 0, 0, 0);
    glClear(GL_COLOR_BUFFER_BIT);
    glDrawArrays(GL_TRIANGLES, 0, 3);
    std::vector<float> rgba(size_t(o.size) * o.size * 4);
    glReadPixels(0, 0, o.size, o.size, GL_RGBA, GL_FLOAT, rgba.data());
    if (const GLenum e = glGetError(); e != GL_NO_ERROR)
      status = Internal("GL error " + std::to_string(e) + " while rendering on " + s_->description);
    Image out(o.size, o.size, 4);
    for (int r = 0; r < o.size; ++r)  // GL rows run bottom-up
      for (int x = 0; x < o.size; ++x)
        for (int c = 0; c < 4; ++c)
          out.Plane(c)[int64_t(o.size - 1 - r) * o.size + x] =
              rgba[(size_t(r) * o.size + x) * 4 + c];
    glDeleteFramebuffers(1, &fbo);
    glDeleteRenderbuffers(1, &rb);
    glDeleteTextures(1, &tex);
    if (table) glDeleteTextures(1, &table);
    if (status.ok()) return out;
    return status;
  }
  glDeleteFramebuffers(1, &fbo);
  glDeleteRenderbuffers(1, &rb);
  glDeleteTextures(1, &tex);
  if (table) glDeleteTextures(1, &table);
  return status;
}

}  // namespace matfit::render
