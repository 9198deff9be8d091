#include "core/synth/random.h"

#include <cmath>
#include <numbers>

namespace matfit::synth {
namespace {

uint64_t Mix(uint64_t z) {
  z += 0x9e3779b97f4a7c15ULL;
  z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ULL;
  z = (z ^ (z >> 27)) * 0x94d049bb133111ebULL;
  return z ^ (z >> 31);
}

int Wrap(int i, int p) { return ((i % p) + p) % p; }

double Quintic(double t) { return t * t * t * (t * (t * 6 - 15) + 10); }

}  // namespace

uint64_t Hash(uint64_t seed, uint64_t a, uint64_t b, uint64_t c) {
  return Mix(Mix(Mix(Mix(seed) ^ a) ^ b) ^ c);
}

double HashUniform(uint64_t seed, uint64_t a, uint64_t b, uint64_t c) {
  return double(Hash(seed, a, b, c) >> 11) * 0x1.0p-53;
}

double HashGaussian(uint64_t seed, uint64_t a, uint64_t b, uint64_t c) {
  const uint64_t h = Hash(seed, a, b, c);
  const double u1 = (double(h >> 11) + 0.5) * 0x1.0p-53;  // (0, 1)
  const double u2 = double(Mix(h) >> 11) * 0x1.0p-53;
  return std::sqrt(-2.0 * std::log(u1)) * std::cos(2.0 * std::numbers::pi * u2);
}

double ValueNoise(uint64_t seed, double u, double v, int period) {
  const double fu = std::floor(u), fv = std::floor(v);
  const int iu = int(fu), iv = int(fv);
  const double tu = Quintic(u - fu), tv = Quintic(v - fv);
  auto at = [&](int a, int b) {
    return HashUniform(seed, uint64_t(Wrap(a, period)), uint64_t(Wrap(b, period)));
  };
  const double a = at(iu, iv), b = at(iu + 1, iv), c = at(iu, iv + 1), d = at(iu + 1, iv + 1);
  return (a + (b - a) * tu) * (1 - tv) + (c + (d - c) * tu) * tv;
}

double Fbm(uint64_t seed, double u, double v, int base_freq, int octaves) {
  double sum = 0, norm = 0, amp = 1;
  int freq = base_freq;
  for (int o = 0; o < octaves; ++o) {
    sum += amp * ValueNoise(seed + 7919 * o, u * freq, v * freq, freq);
    norm += amp;
    amp *= 0.5;
    freq *= 2;
  }
  return sum / norm;
}

CellSample Cellular(uint64_t seed, double u, double v, int freq) {
  const double x = u * freq, y = v * freq;
  const int cx = int(std::floor(x)), cy = int(std::floor(y));
  CellSample best{1e30, 0};
  for (int dy = -1; dy <= 1; ++dy)
    for (int dx = -1; dx <= 1; ++dx) {
      const int gx = cx + dx, gy = cy + dy;
      const uint64_t id = uint64_t(Wrap(gx, freq)) * 1000003ULL + uint64_t(Wrap(gy, freq));
      const double px = gx + HashUniform(seed, id, 1), py = gy + HashUniform(seed, id, 2);
      const double d = std::hypot(px - x, py - y);
      if (d < best.distance) best = {d, id};
    }
  return best;
}

}  // namespace matfit::synth
