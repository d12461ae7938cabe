#include "drivers/gphoto2/gphoto2_values.h"

#include <gphoto2/gphoto2-port-result.h>
#include <gphoto2/gphoto2-result.h>
#include <gtest/gtest.h>

namespace relume::drivers::gphoto2 {
namespace {

TEST(Gphoto2ValuesTest, ParsesShutterSpeedLabels) {
  EXPECT_DOUBLE_EQ(*ParseShutterSpeedS("1/4000"), 1.0 / 4000.0);
  EXPECT_DOUBLE_EQ(*ParseShutterSpeedS("0.3"), 0.3);
  EXPECT_DOUBLE_EQ(*ParseShutterSpeedS("30"), 30.0);
  EXPECT_DOUBLE_EQ(*ParseShutterSpeedS("30s"), 30.0);
  EXPECT_DOUBLE_EQ(*ParseShutterSpeedS("2\""), 2.0);
  EXPECT_DOUBLE_EQ(*ParseShutterSpeedS(" 10/10 "), 1.0);
}

TEST(Gphoto2ValuesTest, NonNumericShutterLabelsAreNotNumbers) {
  EXPECT_FALSE(ParseShutterSpeedS("bulb"));
  EXPECT_FALSE(ParseShutterSpeedS("auto"));
  EXPECT_FALSE(ParseShutterSpeedS("1/0"));
  EXPECT_FALSE(ParseShutterSpeedS(""));
  EXPECT_FALSE(ParseShutterSpeedS("-1"));
}

TEST(Gphoto2ValuesTest, ParsesApertureIsoAndEv) {
  EXPECT_DOUBLE_EQ(*ParseApertureF("f/5.6"), 5.6);
  EXPECT_DOUBLE_EQ(*ParseApertureF("F/11"), 11.0);
  EXPECT_DOUBLE_EQ(*ParseApertureF("2.8"), 2.8);
  EXPECT_FALSE(ParseApertureF("implicit auto"));
  EXPECT_DOUBLE_EQ(*ParseIso("400"), 400.0);
  EXPECT_DOUBLE_EQ(*ParseIso("ISO 800"), 800.0);
  EXPECT_FALSE(ParseIso("Auto"));
  EXPECT_DOUBLE_EQ(*ParseEvCompensation("-1.3"), -1.3);
  EXPECT_DOUBLE_EQ(*ParseEvCompensation("+0.7"), 0.7);
  EXPECT_DOUBLE_EQ(*ParseEvCompensation("0"), 0.0);
}

TEST(Gphoto2ValuesTest, MatchesChoicesWithinTolerance) {
  const std::vector<std::string> shutter = {"1/4000", "1/3200", "1/60", "0.3", "bulb", "30"};
  EXPECT_EQ(MatchChoice(ValueKind::kShutterSpeed, shutter, 1.0 / 60.0), 2);
  EXPECT_EQ(MatchChoice(ValueKind::kShutterSpeed, shutter, 1.0 / 3.0), -1);  // 0.3 is 10% off
  EXPECT_EQ(MatchChoice(ValueKind::kShutterSpeed, shutter, 0.301), 3);
  EXPECT_EQ(MatchChoice(ValueKind::kShutterSpeed, shutter, 1.0 / 3000.0), -1);  // between third stops
  EXPECT_EQ(MatchChoice(ValueKind::kShutterSpeed, shutter, 30.0), 5);
  const std::vector<std::string> ev = {"-0.7", "-0.3", "0", "0.3", "0.7"};
  EXPECT_EQ(MatchChoice(ValueKind::kEvCompensation, ev, -1.0 / 3.0), 1);
  EXPECT_EQ(MatchChoice(ValueKind::kEvCompensation, ev, 0.5), -1);
  EXPECT_EQ(MatchChoice(ValueKind::kEvCompensation, ev, 0.0), 2);
}

TEST(Gphoto2ValuesTest, NumericChoicesAreSortedAndSkipWords) {
  const std::vector<double> iso = NumericChoices(ValueKind::kIso, {"Auto", "400", "100", "200", "100"});
  EXPECT_EQ(iso, (std::vector<double>{100.0, 200.0, 400.0}));
}

TEST(Gphoto2ValuesTest, NamesFileFormats) {
  EXPECT_EQ(FileFormat("IMG_0001.JPG", ""), "jpeg");
  EXPECT_EQ(FileFormat("DSC_0001.NEF", "image/x-nikon-nef"), "nef");
  EXPECT_EQ(FileFormat("capt0000.cr2", ""), "cr2");
  EXPECT_EQ(FileFormat("SIM_0001.TIF", ""), "tiff");
  EXPECT_EQ(FileFormat("noextension", "image/jpeg"), "jpeg");
  EXPECT_EQ(FileFormat("noextension", ""), "");
}

TEST(Gphoto2ValuesTest, MapsResultCodesOntoDeviceErrors) {
  EXPECT_EQ(KindFromGphotoResult(GP_ERROR_CAMERA_BUSY, false), DeviceErrorKind::kBusy);
  EXPECT_EQ(KindFromGphotoResult(GP_ERROR_TIMEOUT, false), DeviceErrorKind::kTimeout);
  EXPECT_EQ(KindFromGphotoResult(GP_ERROR_IO_READ, false), DeviceErrorKind::kIo);
  EXPECT_EQ(KindFromGphotoResult(GP_ERROR_IO, false), DeviceErrorKind::kIo);
  EXPECT_EQ(KindFromGphotoResult(GP_ERROR_IO_USB_CLAIM, false), DeviceErrorKind::kAccessDenied);
  EXPECT_EQ(KindFromGphotoResult(GP_ERROR_IO_LOCK, true), DeviceErrorKind::kAccessDenied);
  EXPECT_EQ(KindFromGphotoResult(GP_ERROR_IO_USB_FIND, false), DeviceErrorKind::kDisconnected);
  EXPECT_EQ(KindFromGphotoResult(GP_ERROR_IO_USB_FIND, true), DeviceErrorKind::kNotFound);
  EXPECT_EQ(KindFromGphotoResult(GP_ERROR_MODEL_NOT_FOUND, true), DeviceErrorKind::kNotFound);
  EXPECT_EQ(KindFromGphotoResult(GP_ERROR_CORRUPTED_DATA, false), DeviceErrorKind::kCorruptFrame);
  EXPECT_EQ(KindFromGphotoResult(GP_ERROR_NOT_SUPPORTED, false), DeviceErrorKind::kUnsupportedSetting);
  EXPECT_EQ(KindFromGphotoResult(GP_ERROR, false), DeviceErrorKind::kIo);
  EXPECT_NE(std::string(ClaimedByAnotherProcessHint()).find("gio mount -s gphoto2"), std::string::npos);
}

}  // namespace
}  // namespace relume::drivers::gphoto2
