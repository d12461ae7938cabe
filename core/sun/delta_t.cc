#include "core/sun/delta_t.h"

namespace relume {

namespace {
// Horner evaluation of c[0] + c[1] t + c[2] t^2 + ...
template <int N>
double Polynomial(const double (&c)[N], double t) {
  double sum = 0.0;
  for (int i = N - 1; i >= 0; --i) sum = sum * t + c[i];
  return sum;
}
double LongTermParabola(double year) {
  const double u = (year - 1820.0) / 100.0;
  return -20.0 + 32.0 * u * u;
}
}  // namespace

double DeltaTModelSeconds(double y) {
  if (y < 1800.0 || y >= 2150.0) return LongTermParabola(y);
  if (y < 1860.0) {
    static constexpr double c[] = {13.72,       -0.332447,    0.0068612,     0.0041116,
                                   -0.00037436, 0.0000121272, -0.0000001699, 0.000000000875};
    return Polynomial(c, y - 1800.0);
  }
  if (y < 1900.0) {
    static constexpr double c[] = {7.62, 0.5737, -0.251754, 0.01680668, -0.0004473624, 1.0 / 233174.0};
    return Polynomial(c, y - 1860.0);
  }
  if (y < 1920.0) {
    static constexpr double c[] = {-2.79, 1.494119, -0.0598939, 0.0061966, -0.000197};
    return Polynomial(c, y - 1900.0);
  }
  if (y < 1941.0) {
    static constexpr double c[] = {21.20, 0.84493, -0.076100, 0.0020936};
    return Polynomial(c, y - 1920.0);
  }
  if (y < 1961.0) {
    static constexpr double c[] = {29.07, 0.407, -1.0 / 233.0, 1.0 / 2547.0};
    return Polynomial(c, y - 1950.0);
  }
  if (y < 1986.0) {
    static constexpr double c[] = {45.45, 1.067, -1.0 / 260.0, -1.0 / 718.0};
    return Polynomial(c, y - 1975.0);
  }
  if (y < 2005.0) {
    static constexpr double c[] = {63.86, 0.3345, -0.060374, 0.0017275, 0.000651814, 0.00002373599};
    return Polynomial(c, y - 2000.0);
  }
  if (y < 2050.0) {
    static constexpr double c[] = {62.92, 0.32217, 0.005589};
    return Polynomial(c, y - 2000.0);
  }
  // 2050-2150: the parabola, with a linear term that removes the jump at 2050.
  return LongTermParabola(y) - 0.5628 * (2150.0 - y);
}

}  // namespace relume
