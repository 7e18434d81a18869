#pragma once
// Puts live messages together into scans: what a subscriber receives, on several channels and in
// no promised order, becomes one ScanMessages per point cloud. LCM-free and clock-free (the
// caller says when each message came), so it is tested without a network.
//
// A scan starts with its point cloud. Labels and poses are matched to it by frame_id, whether
// they came before it (held, up to `max_held` scans' worth) or after (within `wait_s`); samples by
// time, as in a log (those since the scan before, up to its own time). A grid's layer origins
// (channels.grid_origins) are matched like labels but not waited for: the sender puts them
// before the grid. A scan is ready once it
// has everything its channels promise, or when its wait has run out; scans leave in the order
// their clouds came.
#include <cstddef>
#include <cstdint>
#include <deque>
#include <map>
#include <optional>
#include <set>
#include <string>
#include <vector>

#include "terramrf/lcm/log_frame_index.hpp"
#include "terramrf/lcm/scan_messages.hpp"

namespace terramrf {

class ScanAssembler {
 public:
  struct Options {
    LogChannels channels;  ///< as for a log; "" = not read
    /// How long a scan waits after its cloud for labels and poses still missing [s]. 0: a scan
    /// is ready with its cloud (what came before it is all it gets).
    double wait_s = 0.5;
    /// Scans whose labels or poses may be held before their cloud; the oldest are dropped
    /// (counted) beyond it, so that a sender of labels without clouds cannot fill memory.
    std::size_t max_held = 64;
    /// Samples held for the next cloud at most; the oldest are dropped (counted) beyond it.
    std::size_t max_samples = 100000;
    /// Scans waiting to leave at most: when the consumer falls behind the sender, the oldest
    /// are dropped (counted) so that memory stays bounded and the newest scans are the ones run.
    std::size_t max_waiting = 16;
    /// Cameras a scan waits for, an image_t and a camera_info_t of each (channels.images,
    /// channels.camera_info; a truth image on channels.image_truth is taken if it comes, not
    /// waited for); images of other cameras are dropped (counted). Empty = images not read.
    std::vector<std::string> cameras;
    /// Bytes of messages held for scans whose cloud has not come, at most; the oldest scans'
    /// are dropped (counted) beyond it. Images make most of it (about 1.4 MB for KITTI's).
    std::size_t max_held_bytes = 64u << 20;
  };

  /// A ready scan, or a message that could not be placed: `error` (with `error_source`, for an
  /// InputError) instead of `scan`.
  struct Ready {
    std::optional<ScanMessages> scan;
    std::string error_source, error;
  };

  /// What went unused, for the run's notes.
  struct Counts {
    std::size_t late = 0;       ///< labels or poses that came after their scan had left
    std::size_t unclaimed = 0;  ///< held messages never claimed by a cloud (or over the bounds)
    std::size_t unnamed = 0;    ///< labels or poses without a frame_id (nothing to match)
    std::size_t foreign = 0;    ///< messages of another type on a channel read
    std::size_t samples_dropped = 0;  ///< beyond max_samples, or left at the end (flush)
    std::size_t scans_dropped = 0;    ///< beyond max_waiting: the consumer fell behind
    std::size_t incomplete = 0;  ///< scans that left without labels or poses their channels read
    std::size_t unlisted = 0;    ///< images and calibrations of cameras not in Options::cameras
    bool any() const {
      return late || unclaimed || unnamed || foreign || samples_dropped || scans_dropped ||
             incomplete || unlisted;
    }
  };

  explicit ScanAssembler(Options options);

  /// A message received on `channel` at `now_s` (any steady clock [s]); channels not read are
  /// ignored.
  void add(const std::string& channel, const std::uint8_t* data, std::size_t size, double now_s);
  /// The oldest scan (or placement error) ready at `now_s`, if any.
  std::optional<Ready> pop(double now_s);
  /// When the oldest waiting scan will be ready at the latest (to bound the caller's wait).
  std::optional<double> nextDeadline() const;
  /// Ends every wait: what is held is all that will come (the stream ended). Held labels and
  /// poses, and samples after the last cloud, are counted as unused.
  void flush();
  bool empty() const { return ready_.empty() && waiting_.empty(); }
  const Counts& counts() const { return counts_; }

 private:
  struct Cameras {
    std::vector<ScanMessage> images, infos, truths;
    std::set<std::string> image_of, info_of, truth_of;  ///< cameras they are of
    std::string error;  ///< a second message of one kind for one camera
  };
  struct Waiting {
    ScanMessages scan;
    Cameras cameras;
    double deadline_s = 0;
    std::string error;  ///< two labels or poses for it
  };
  struct Held {
    std::optional<ScanMessage> labels, pose, truth_pose, grid, grid_origins;
    Cameras cameras;
    std::string error;
  };
  /// kind: 0 image, 1 calibration, 2 truth image.
  void placeCamera(int kind, const std::string& id, const std::string& camera, ScanMessage m);
  void evictHeld();
  /// The waiting scan `id`, if its cloud came.
  Waiting* waitingScan(const std::string& id);
  /// Where messages of a scan whose cloud has not come are held; nullptr (counted late) if the
  /// scan already left.
  Held* heldFor(const std::string& id);
  std::size_t held_bytes_ = 0;
  bool complete(const Waiting& w) const;
  static std::size_t messages(const Held& h);
  static std::size_t bytes(const Held& h);
  void place(std::optional<ScanMessage> Held::*held_slot, std::optional<ScanMessage> ScanMessages::*slot,
             const std::string& type, const std::string& id, ScanMessage m);

  Options o_;
  std::deque<Waiting> waiting_;
  std::deque<Ready> ready_;  ///< placement errors, in the order they came
  std::map<std::string, Held> held_;
  std::deque<std::string> held_order_;
  std::deque<std::string> recent_;  ///< ids of scans that left, to tell late messages
  struct Sample {
    std::int64_t utime;
    int kind;  // 0 imu, 1 gps, 2 odometry
    ScanMessage message;
  };
  std::deque<Sample> samples_;
  std::size_t clouds_ = 0;
  Counts counts_;
};

}  // namespace terramrf
