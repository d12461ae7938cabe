// delta_t = TT - UT1, the difference between uniform (terrestrial) time and Earth-rotation
// time, in seconds.
//
// Measured values are published by the IERS (about 69.2 s in 2025); pass them when known.
// When not, relume uses the Espenak & Meeus (2006) polynomial model for NASA's eclipse
// canon. Its 2005-2050 branch was an extrapolation and overestimates the real delta_t by
// about 4-5 s in the 2020s. The sun's apparent position depends on delta_t only through its
// orbital motion (0.04 deg/h), so 5 s of delta_t error moves it by at most 0.00006 deg.
#pragma once

namespace relume {

// Espenak & Meeus (2006) delta_t in seconds for a decimal year. Valid 1800-2150 as fitted;
// outside, the Morrison & Stephenson long-term parabola -20 + 32 u^2, u = (year-1820)/100.
double DeltaTModelSeconds(double decimal_year);

}  // namespace relume
