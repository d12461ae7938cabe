// What the maker of a simulated RGB-D sensor would ship with it: its colour camera's response,
// written into the session by capture as a "response" calibration row (the format `relume
// calibrate response` stores, calibration/calibration_profile.h), so that processing linearises
// the colour stream from the session and never from the simulator's camera model.
//
// Why RGB-D colour cameras only: they stream single exposures, so no bracket in the session can
// recover their response; a real sensor's response comes from its maker or from `relume
// calibrate response` on a bracket shot with it. Still cameras shoot brackets, and their
// response is recovered from them (a factory row would hide what calibration measures).
//
// The row's inverse response is in absolute units: inverse[c][z] / (t * ISO / 100) is the
// radiance (W m^-2 sr^-1) that code z means at exposure time t, at the sensor's fixed aperture,
// ISO and gain. The camera model's vignetting is not part of a response; a sensor whose model
// has vignetting gets no row (processing then says it assumes sRGB), never a row that is wrong
// away from the image centre.
#pragma once

#include <optional>
#include <string>
#include <vector>

#include "calibration/calibration_profile.h"
#include "capture/session.h"
#include "core/time.h"
#include "rig/rig_config.h"

namespace relume::rig {

// The colour camera's response of one simulated RGB-D device, or nullopt (with the reason in
// `why`) when the device is not an RGB-D sensor or its model has vignetting.
std::optional<calibration::CalibrationProfile> FactoryColorResponse(const sim::SimDeviceSpec& spec,
                                                                    std::string* why = nullptr);

// One "response" calibration row per simulated RGB-D sensor of the rig (device ids "sim:ID").
std::vector<capture::CalibrationRecord> FactoryResponseRecords(const RigConfig& rig, UtcTime created);

}  // namespace relume::rig
