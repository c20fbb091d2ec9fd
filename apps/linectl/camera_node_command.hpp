// linectl camera serve: a stand-alone camera node (issue 4 item 2; docs/vision.md, "The camera
// node"). It takes frames from a camera device, a video file, a directory of images or one
// camera of an MCAP recording, measures each with the estimator and publishes the result on
// DDS as fl::CameraEstimates: the same CameraFrame the in-process input path hands the
// controller, so `linectl control` (or any DdsCameraInput) sees one structure either way.
//   linectl camera serve --camera orientation --calibration CAM.yaml --device 0
//   linectl camera serve --recording run.mcap [--speed 2] [--json node.json]
#pragma once

#include <CLI/CLI.hpp>
#include <string>
#include <vector>

namespace fl::apps {

struct CameraServeArgs {
  std::string camera = "orientation";  // which line camera this node is
  std::string calibration;             // belt calibration; a recording's own by default
  std::string recording;
  std::string images_dir;
  std::string video_file;
  int device = -1;
  double fps = 25.0;                            // --images (and a video file that reports no rate)
  double speed = 1.0;                           // files: serve at this multiple of their own pace
  std::string duration;                         // empty: until the source ends or a stop signal
  std::vector<std::string> estimator_settings;  // NAME=VALUE
  int domain = -1;                              // -1: the domain of CYCLONEDDS_URI's configuration
  std::string wait = "30s";                     // how long to wait for a reader before giving up
  std::string json_path;
  std::string record_path;  // set: every frame served (PNG) and the estimates published
};

CLI::App* add_camera_subcommand(CLI::App& app, CameraServeArgs& args);
// 0: the source ended (or the duration or a stop signal came) after at least one frame was
// published; 1: no frame published, or the source failed mid-run; 2: bad options, calibration
// or source; 4: no reader matched within --wait.
int camera_serve_command(const CameraServeArgs& args);

}  // namespace fl::apps
