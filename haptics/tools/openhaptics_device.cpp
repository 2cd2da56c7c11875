// OpenHaptics (HDAPI 3.x) device: written against the OpenHaptics Toolkit API reference
// (hdInitDevice, hdEnable(HD_FORCE_OUTPUT), hdScheduleAsynchronous, hdStartScheduler,
// hdBeginFrame / hdEndFrame, hdGetDoublev, hdGetIntegerv, hdSetDoublev, hdGetError).
//
//   HD scheduler thread (vendor, 1 kHz)                  bridge servo thread (ours, 1 kHz)
//   callback: begin frame ─► read position, velocity,  ◄─ read(): the newest sample
//             transform, buttons ─► set the force       ─► write(F): the force for the next frames
//             ─► end frame (HD sends the force)
//
// The vendor's scheduler owns the device; our servo exchanges one sample and one force with it
// through a small mutex-guarded mailbox (try_lock in the callback: it never waits; a busy mailbox
// keeps the previous force for one more tick). HDAPI units are millimetres and mm/s: converted
// to metres here; forces are newtons on both sides. HD_CURRENT_TRANSFORM is a column-major 4x4
// matrix whose rotation is the stylus orientation.
#include "haptics/tools/openhaptics_device.h"

#include <HD/hd.h>

#include <chrono>
#include <cstdio>
#include <mutex>

namespace sph::haptics {

namespace {

// HDAPI's last error as text ("" when none).
std::string hdErrorText() {
  const HDErrorInfo e = hdGetError();
  if (!HD_DEVICE_ERROR(e)) return "";
  const char* s = hdGetErrorString(e.errorCode);
  return std::string(s ? s : "unknown HDAPI error") + " (HD error 0x" + [&] {
    char buf[16];
    std::snprintf(buf, sizeof buf, "%04x", static_cast<unsigned>(e.errorCode));
    return std::string(buf);
  }() + ", internal " + std::to_string(e.internalErrorCode) + ")";
}

class OpenHapticsDevice : public Device {
 public:
  explicit OpenHapticsDevice(std::string name) : name_(std::move(name)) {}
  ~OpenHapticsDevice() override { close(); }

  void open() override {
    if (handle_ != HD_INVALID_HANDLE) return;
    // Initialise the device and read its nominal limits (HD: N, N/mm, N s/mm).
    handle_ = hdInitDevice(name_.empty() ? static_cast<HDstring>(HD_DEFAULT_DEVICE) : name_.c_str());
    if (const std::string err = hdErrorText(); !err.empty()) {
      handle_ = HD_INVALID_HANDLE;
      throw DeviceError("OpenHaptics device '" + (name_.empty() ? std::string("default") : name_) + "': " + err);
    }
    HDdouble max_force = 0, max_cont = 0, max_k = 0, max_b = 0;
    hdGetDoublev(HD_NOMINAL_MAX_FORCE, &max_force);
    hdGetDoublev(HD_NOMINAL_MAX_CONTINUOUS_FORCE, &max_cont);
    hdGetDoublev(HD_NOMINAL_MAX_STIFFNESS, &max_k);
    hdGetDoublev(HD_NOMINAL_MAX_DAMPING, &max_b);
    const char* model = hdGetString(HD_DEVICE_MODEL_TYPE);
    spec_.name = std::string("openhaptics ") + (model ? model : "device");
    if (max_force > 0) spec_.max_force = max_force;
    if (max_cont > 0) spec_.max_continuous_force = max_cont;
    if (max_k > 0) spec_.max_stiffness = max_k * 1e3;  // N/mm -> N/m
    if (max_b > 0) spec_.max_damping = max_b * 1e3;    // N s/mm -> N s/m
    // Forces on; the servo callback at the scheduler's rate (1 kHz).
    hdEnable(HD_FORCE_OUTPUT);
    hdSetSchedulerRate(1000);
    callback_ = hdScheduleAsynchronous(&OpenHapticsDevice::servo, this, HD_MAX_SCHEDULER_PRIORITY);
    hdStartScheduler();
    if (const std::string err = hdErrorText(); !err.empty()) {
      close();
      throw DeviceError("OpenHaptics scheduler: " + err);
    }
  }

  void close() override {
    if (handle_ == HD_INVALID_HANDLE) return;
    // Zero force first, then stop the scheduler and release the device.
    {
      std::lock_guard<std::mutex> lock(mutex_);
      force_.setZero();
    }
    hdStopScheduler();
    hdUnschedule(callback_);
    hdDisableDevice(handle_);
    handle_ = HD_INVALID_HANDLE;
  }

  DeviceSpec spec() const override { return spec_; }

  void read(DeviceState& s) override {
    std::lock_guard<std::mutex> lock(mutex_);
    if (!fault_.empty()) throw DeviceError(spec_.name + ": " + fault_);
    s = sample_;
    s.time = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0_).count();
  }

  void write(const Eigen::Vector3d& force) override {
    std::lock_guard<std::mutex> lock(mutex_);
    force_ = force;
  }

 private:
  // The vendor's servo callback: one device frame per scheduler tick.
  static HDCallbackCode HDCALLBACK servo(void* data) {
    auto* self = static_cast<OpenHapticsDevice*>(data);
    hdBeginFrame(hdGetCurrentDevice());
    HDdouble p[3], v[3], m[16];
    HDint buttons = 0;
    hdGetDoublev(HD_CURRENT_POSITION, p);   // mm
    hdGetDoublev(HD_CURRENT_VELOCITY, v);   // mm/s
    hdGetDoublev(HD_CURRENT_TRANSFORM, m);  // column-major, rotation = stylus
    hdGetIntegerv(HD_CURRENT_BUTTONS, &buttons);
    HDdouble f[3] = {0, 0, 0};
    if (self->mutex_.try_lock()) {
      self->sample_.position = 1e-3 * Eigen::Vector3d(p[0], p[1], p[2]);
      self->sample_.velocity = 1e-3 * Eigen::Vector3d(v[0], v[1], v[2]);
      Eigen::Matrix3d r;
      r << m[0], m[4], m[8], m[1], m[5], m[9], m[2], m[6], m[10];
      self->sample_.orientation = Eigen::Quaterniond(r).normalized();
      self->sample_.buttons = static_cast<uint32_t>(buttons);
      self->last_force_ = self->force_;
      self->mutex_.unlock();
    }
    f[0] = self->last_force_.x();
    f[1] = self->last_force_.y();
    f[2] = self->last_force_.z();
    hdSetDoublev(HD_CURRENT_FORCE, f);
    hdEndFrame(hdGetCurrentDevice());
    // A device error (e.g. HD_EXCEEDED_MAX_FORCE, a communication error) is kept for read() to
    // report; the callback goes on so that the device stays safe (the servo fades out).
    if (const std::string err = hdErrorText(); !err.empty() && self->mutex_.try_lock()) {
      self->fault_ = err;
      self->mutex_.unlock();
    }
    return HD_CALLBACK_CONTINUE;
  }

  std::string name_;
  HHD handle_ = HD_INVALID_HANDLE;
  HDSchedulerHandle callback_ = 0;
  DeviceSpec spec_;
  std::chrono::steady_clock::time_point t0_ = std::chrono::steady_clock::now();
  std::mutex mutex_;                                   // guards sample_, force_, fault_
  DeviceState sample_;
  Eigen::Vector3d force_ = Eigen::Vector3d::Zero();    // from write() (unit: N)
  Eigen::Vector3d last_force_ = Eigen::Vector3d::Zero();  // callback thread only (unit: N)
  std::string fault_;
};

}  // namespace

std::unique_ptr<Device> makeOpenHapticsDevice(const std::string& name) { return std::make_unique<OpenHapticsDevice>(name); }

}  // namespace sph::haptics
