// USB enumeration, recognition and hotplug through the real libusb, with devices described
// to it by umockdev (sysfs attributes, descriptors, uevents). Runs under umockdev-wrapper.
#include "drivers/usb/usb_devices.h"

#include <gtest/gtest.h>
#include <libusb.h>
#include <umockdev.h>

#include <condition_variable>
#include <cstring>
#include <mutex>
#include <thread>

namespace relume::drivers::usb {
namespace {

class UsbTestbed : public ::testing::Test {
 protected:
  void SetUp() override {
    if (getenv("LD_PRELOAD") == nullptr || std::strstr(getenv("LD_PRELOAD"), "umockdev") == nullptr) {
      GTEST_SKIP() << "not running under umockdev-wrapper (CTest adds it; run `umockdev-wrapper usb_test` by hand)";
    }
    testbed_ = umockdev_testbed_new();
  }
  void TearDown() override {
    if (testbed_ != nullptr) g_object_unref(testbed_);
  }

  // Adds a USB device node as the kernel would show it: sysfs attributes, a device
  // descriptor (+ one configuration) in "descriptors", udev properties.
  std::string AddUsb(const char* name, std::uint16_t vid, std::uint16_t pid, int bus, int devnum) {
    char vid_text[8], pid_text[8], bus_text[8], dev_text[8], node[32];
    std::snprintf(vid_text, sizeof(vid_text), "%04x", vid);
    std::snprintf(pid_text, sizeof(pid_text), "%04x", pid);
    std::snprintf(bus_text, sizeof(bus_text), "%03d", bus);
    std::snprintf(dev_text, sizeof(dev_text), "%03d", devnum);
    std::snprintf(node, sizeof(node), "bus/usb/%03d/%03d", bus, devnum);
    const std::string busnum = std::to_string(bus), devnum_text = std::to_string(devnum);
    gchar* path = umockdev_testbed_add_device(
        testbed_, "usb", name, nullptr, "idVendor", vid_text, "idProduct", pid_text, "busnum", busnum.c_str(), "devnum",
        devnum_text.c_str(), "speed", "480", "bNumConfigurations", "1", "bConfigurationValue", "1", nullptr, "DEVNAME",
        node, "DEVTYPE", "usb_device", "BUSNUM", bus_text, "DEVNUM", dev_text, nullptr);
    std::uint8_t descriptors[18 + 9] = {18, 1, 0x00, 0x02, 0, 0, 0, 64, static_cast<std::uint8_t>(vid & 0xff),
                                        static_cast<std::uint8_t>(vid >> 8), static_cast<std::uint8_t>(pid & 0xff),
                                        static_cast<std::uint8_t>(pid >> 8), 0, 1, 0, 0, 0, 1,
                                        // configuration descriptor, no interfaces
                                        9, 2, 9, 0, 0, 1, 0, 0x80, 50};
    umockdev_testbed_set_attribute_binary(testbed_, path, "descriptors", descriptors, sizeof(descriptors));
    std::string out = path;
    g_free(path);
    return out;
  }

  UMockdevTestbed* testbed_ = nullptr;
};

TEST(KnownUsbDevicesTest, RecognisesVendorsAndSpecificProducts) {
  EXPECT_EQ(RecogniseUsbDevice(0x04a9, 0x3218)->name, "Canon DSLR");
  EXPECT_EQ(RecogniseUsbDevice(0x04b0, 0x0428)->backend, "gphoto2");
  EXPECT_EQ(RecogniseUsbDevice(0x054c, 0x0994)->kind, DeviceKind::kStillCamera);
  EXPECT_EQ(RecogniseUsbDevice(0x045e, 0x02ae)->kind, DeviceKind::kRgbdSensor);
  EXPECT_FALSE(RecogniseUsbDevice(0x045e, 0x0745));  // a Microsoft mouse receiver is not the Kinect
  EXPECT_EQ(RecogniseUsbDevice(0x1d27, 0x0601)->backend, "openni2");
  EXPECT_EQ(RecogniseUsbDevice(0x8086, 0x0b07)->kind, DeviceKind::kRgbdSensor);
  EXPECT_FALSE(RecogniseUsbDevice(0x1234, 0x5678));
}

TEST(KnownUsbDevicesTest, OpenFailureMessagesSayWhatToDo) {
  const std::string access = DescribeOpenFailure(LIBUSB_ERROR_ACCESS, 0x04a9, 0x3218, 1, 5);
  EXPECT_NE(access.find("/dev/bus/usb/001/005"), std::string::npos) << access;
  EXPECT_NE(access.find("ATTR{idVendor}==\"04a9\""), std::string::npos) << access;
  EXPECT_NE(access.find("plugdev"), std::string::npos) << access;
  const std::string busy = DescribeOpenFailure(LIBUSB_ERROR_BUSY, 0x04b0, 0x0428, 2, 7);
  EXPECT_NE(busy.find("GVFS"), std::string::npos) << busy;
  EXPECT_NE(busy.find("gvfs-gphoto2-volume-monitor"), std::string::npos) << busy;
  EXPECT_NE(DescribeOpenFailure(LIBUSB_ERROR_NO_DEVICE, 1, 2, 3, 4).find("went away"), std::string::npos);
}

TEST_F(UsbTestbed, EnumeratesAndRecognisesDescribedDevices) {
  AddUsb("1-1", 0x04a9, 0x3218, 1, 5);  // Canon
  AddUsb("1-2", 0x045e, 0x02ae, 1, 6);  // Kinect camera
  AddUsb("2-1", 0x1234, 0x5678, 2, 3);  // something else
  UsbEnumerateOptions options;
  options.try_open = false;
  const std::vector<UsbDeviceEntry> known = EnumerateUsb(options);
  ASSERT_EQ(known.size(), 2u);
  std::map<std::uint16_t, UsbDeviceEntry> by_vendor;
  for (const UsbDeviceEntry& e : known) by_vendor[e.vendor_id] = e;
  EXPECT_EQ(by_vendor.at(0x04a9).product_id, 0x3218);
  EXPECT_EQ(by_vendor.at(0x04a9).bus, 1);
  EXPECT_EQ(by_vendor.at(0x04a9).address, 5);
  EXPECT_EQ(by_vendor.at(0x04a9).known->name, "Canon DSLR");
  EXPECT_EQ(by_vendor.at(0x045e).known->kind, DeviceKind::kRgbdSensor);

  options.include_unknown = true;
  EXPECT_EQ(EnumerateUsb(options).size(), 3u);

  const std::vector<DeviceInfo> infos = ListUsbDevices();
  ASSERT_EQ(infos.size(), 2u);
  for (const DeviceInfo& info : infos) {
    EXPECT_EQ(info.backend, "usb");
    EXPECT_NE(info.id.find('@'), std::string::npos) << info.id;
    // No device node exists in the testbed, so the open check reports the device as gone.
    EXPECT_EQ(info.details.at("openable"), "no");
    EXPECT_NE(info.details.at("problem").find("went away"), std::string::npos) << info.details.at("problem");
  }
}

struct EventLog {
  std::mutex mutex;
  std::condition_variable changed;
  std::vector<UsbHotplugEvent> events;
  void Add(const UsbHotplugEvent& e) {
    std::lock_guard<std::mutex> lock(mutex);
    events.push_back(e);
    changed.notify_all();
  }
  // Waits (bounded) for an event of `change` for vendor `vid`.
  std::optional<UsbHotplugEvent> WaitFor(UsbHotplugEvent::Change change, std::uint16_t vid) {
    std::unique_lock<std::mutex> lock(mutex);
    std::optional<UsbHotplugEvent> found;
    changed.wait_for(lock, std::chrono::seconds(5), [&] {
      for (const UsbHotplugEvent& e : events) {
        if (e.change == change && e.vendor_id == vid) found = e;
      }
      return found.has_value();
    });
    return found;
  }
};

void ExpectArrivalAndRemoval(UMockdevTestbed* testbed, EventLog& log, const std::string& path) {
  const UtcTime before = UtcNow();
  umockdev_testbed_uevent(testbed, path.c_str(), "add");
  const std::optional<UsbHotplugEvent> arrived = log.WaitFor(UsbHotplugEvent::Change::kArrived, 0x045e);
  ASSERT_TRUE(arrived) << "no arrival event within 5 s";
  EXPECT_EQ(arrived->product_id, 0x02ae);
  EXPECT_EQ(arrived->bus, 2);
  EXPECT_EQ(arrived->address, 9);
  EXPECT_EQ(arrived->known_name, "Microsoft Kinect (Xbox 360) camera");
  EXPECT_GE(arrived->time, before);
  umockdev_testbed_uevent(testbed, path.c_str(), "remove");
  umockdev_testbed_remove_device(testbed, path.c_str());
  const std::optional<UsbHotplugEvent> left = log.WaitFor(UsbHotplugEvent::Change::kLeft, 0x045e);
  ASSERT_TRUE(left) << "no removal event within 5 s";
  EXPECT_EQ(left->address, 9);
  EXPECT_GE(left->time, arrived->time);
}

TEST_F(UsbTestbed, HotplugCallbacksReportArrivalAndRemoval) {
  EventLog log;
  UsbWatcherOptions options;
  options.only_known = true;
  UsbWatcher watcher([&log](const UsbHotplugEvent& e) { log.Add(e); }, options);
  ASSERT_TRUE(watcher.using_hotplug()) << "libusb here has no hotplug support";
  const std::string path = AddUsb("2-4", 0x045e, 0x02ae, 2, 9);
  ExpectArrivalAndRemoval(testbed_, log, path);
}

TEST_F(UsbTestbed, PollingFallbackReportsArrivalAndRemoval) {
  EventLog log;
  UsbWatcherOptions options;
  options.force_polling = true;
  options.poll_interval = std::chrono::milliseconds(50);
  UsbWatcher watcher([&log](const UsbHotplugEvent& e) { log.Add(e); }, options);
  EXPECT_FALSE(watcher.using_hotplug());
  const std::string path = AddUsb("2-4", 0x045e, 0x02ae, 2, 9);
  ExpectArrivalAndRemoval(testbed_, log, path);
}

TEST(UsbWatcherOptionsTest, PollIntervalMustBeSensible) {
  UsbWatcherOptions options;
  options.poll_interval = std::chrono::milliseconds(1);
  std::string why;
  EXPECT_FALSE(options.IsValid(&why));
  EXPECT_NE(why.find("poll_interval"), std::string::npos);
}

}  // namespace
}  // namespace relume::drivers::usb
