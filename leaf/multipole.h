// Multipole diffusion transmittance of a thin homogeneous slab (METHODS.md §5, corrected form).
// Units: lengths in mm, coefficients in 1/mm, T in 1/mm² (radiant exitance per unit incident
// flux at lateral distance r on the far side of a slab of thickness d).
#pragma once

#include <string>

namespace matfit::leaf {

struct MultipoleParams {
  double g = 0.07;        // scattering anisotropy (510 nm)
  double sigma_s = 10.2;  // scattering coefficient, 1/mm
  double sigma_a = 0.4;   // absorption coefficient, 1/mm
  double rho_d = 0.0;     // average diffuse reflectance of the boundary; A = (1+ρ_d)/(1−ρ_d)
  int dipoles = 3;        // j = −n..n
  bool Check(std::string* why) const;
};

class Multipole {
 public:
  explicit Multipole(const MultipoleParams& p);  // p must pass Check()

  // T(r, d): the corrected multipole sum, 1/mm². Unclamped (may be negative for d ≲ l).
  double Transmittance(double r_mm, double d_mm) const;
  // max(0, T): the tiny negative tail is clamped.
  double Clamped(double r_mm, double d_mm) const;
  // Validity limit of the model, 1.5 l: at d → l the real source reaches the far surface and
  // T(0, d) diverges (d < l: large negative values). Thinner texels are clamped and flagged.
  double min_thickness() const { return min_thickness_; }
  // Radius where T(r, d) falls below `threshold` (1/mm²) for good, mm.
  double Radius(double d_mm, double threshold) const;

  double mean_free_path() const { return l_; }  // l = 1/σ'_t, mm
  double sigma_tr() const { return sigma_tr_; }

 private:
  int n_;
  double alpha_p_, sigma_tr_, l_, zb_;
  double min_thickness_ = 0;
};

}  // namespace matfit::leaf
