// The twin's truth channel (/camera/<name>/truth, JSON): a round trip through the writer, and
// the malformed truth messages a reader must refuse with a RecordingError that names the file,
// the message and the bad field: not JSON, not an object with a 'fillets' array, a fillet
// missing a field, a value of the wrong type or not finite, a group_id that is not a whole
// number in int's range, a header that disagrees with the record, a frame's truth recorded
// twice.
#include <gtest/gtest.h>
#include <unistd.h>

#include <cmath>
#include <filesystem>
#include <limits>
#include <map>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "fl/mcap/writer.hpp"
#include "fl/vision/record/recording.hpp"
#include "record_test_support.hpp"

namespace fl::vision::record {
namespace {

std::filesystem::path temp_file(const std::string& name) {
  return test::temp_file("fl_truth_test", name);
}

using test::small_calibration;

// The frame every hand-made message is the truth of: any sequence but 0 (a default), logged
// at its exposure, 40 ms per frame (25 fps).
constexpr std::uint32_t kFrame = 3;
constexpr std::int64_t kExposureNs = 120'000'000;  // frame 3 at 40 ms per frame

// The fields of one well-formed fillet as JSON text; a test replaces or removes one. The values
// are arbitrary but valid: a pose in view, a group of touching fillets (group 4).
std::map<std::string, std::string> good_fillet() {
  return {{"x_mm", "12.5"},        {"y_mm", "-8.25"},        {"angle_rad", "1.5"},
          {"hand", "\"left\""},    {"side", "\"skin\""},     {"group_id", "4"},
          {"singulated", "false"}, {"fully_visible", "true"}};
}

std::string object_text(const std::map<std::string, std::string>& fields) {
  std::string text = "{";
  for (const auto& [key, value] : fields) {
    if (text.size() > 1) text += ",";
    text += "\"" + key + "\":" + value;
  }
  return text + "}";
}

// A well-formed fillet with `key` set to the JSON text `value`, or removed for nullopt.
std::string fillet_with(const std::string& key, const std::optional<std::string>& value) {
  std::map<std::string, std::string> fields = good_fillet();
  if (value) {
    fields[key] = *value;
  } else {
    fields.erase(key);
  }
  return object_text(fields);
}

// A truth message of kFrame on the orientation camera with `fillets` (JSON text of the array's
// items), header as the writer writes it.
std::string message_text(const std::string& fillets) {
  return R"({"camera":"orientation","sequence":3,"exposure_ns":120000000,"fillets":[)" + fillets +
         "]}";
}

// A recording holding nothing but the orientation camera's truth channel with `text` as the
// message of kFrame at kExposureNs: as a damaged or hand-made file would hold it (the
// RecordingWriter writes only well-formed truth).
void write_truth_message(const std::filesystem::path& path, const std::string& text) {
  mcap::Writer writer(path, {});
  const std::string schema = R"({"title": "fl.CameraTruth", "type": "object"})";
  const auto schema_id =
      writer.add_schema("fl.CameraTruth", "jsonschema",
                        {reinterpret_cast<const std::uint8_t*>(schema.data()), schema.size()});
  const auto channel = writer.add_channel(schema_id, truth_topic(CameraId::kOrientation), "json");
  const auto time = static_cast<mcap::Timestamp>(kExposureNs);
  writer.write_message({channel,
                        kFrame,
                        time,
                        time,
                        {reinterpret_cast<const std::uint8_t*>(text.data()), text.size()}});
  writer.close();
}

std::string load_error(const std::filesystem::path& path) {
  try {
    (void)load_recording(path);
  } catch (const RecordingError& error) {
    return error.what();
  }
  return "";
}

// Loads a recording whose truth message of kFrame is `text` and checks that the error names
// the file, the message and every one of `parts` (the field and what is wrong with it).
void expect_truth_error(const std::string& text, const std::vector<std::string>& parts) {
  SCOPED_TRACE(text);
  const auto path = temp_file("malformed.mcap");
  write_truth_message(path, text);
  const std::string error = load_error(path);
  EXPECT_NE(error.find(path.string()), std::string::npos) << error;
  EXPECT_NE(error.find("/camera/orientation/truth message 3 "), std::string::npos) << error;
  for (const std::string& part : parts) {
    EXPECT_NE(error.find(part), std::string::npos) << "no '" << part << "' in: " << error;
  }
  std::filesystem::remove(path);
}

TrueFillet touching_fillet(double x_mm, int group_id) {
  TrueFillet fillet;
  fillet.x_mm = x_mm;
  fillet.y_mm = -8.25;  // any pose in view
  fillet.angle_rad = 1.5;
  fillet.hand = Hand::kRight;
  fillet.side = SideUp::kBone;
  fillet.group_id = group_id;
  fillet.singulated = false;
  fillet.fully_visible = true;
  return fillet;
}

TEST(RecordingTruth, RoundTripsThroughTheWriter) {
  const auto path = temp_file("round_trip.mcap");
  {
    RecordingWriter writer(path, {9, {{"source", "test"}}});  // 9: the smallest file
    writer.add_camera(CameraId::kOrientation, small_calibration());
    // The calibration's 64 x 48 px, belt blue (BGR 165, 105, 35) as the other recording tests.
    writer.write_frame(CameraId::kOrientation, kFrame, kExposureNs,
                       cv::Mat(48, 64, CV_8UC3, cv::Scalar(165, 105, 35)));
    // A touching pair in group 0 and group int max: the ends of the range a group_id may take.
    writer.write_truth(
        CameraId::kOrientation, kFrame, kExposureNs,
        {touching_fillet(12.5, 0), touching_fillet(-40.0, std::numeric_limits<int>::max())});
    writer.close();
  }
  const Recording recording = load_recording(path);
  const auto& truth = recording.cameras[index(CameraId::kOrientation)].truth;
  ASSERT_EQ(truth.size(), 1U);  // one frame's truth
  const std::vector<TrueFillet>& fillets = truth.at(kFrame);
  ASSERT_EQ(fillets.size(), 2U);  // the pair
  EXPECT_EQ(fillets[0].x_mm, 12.5);
  EXPECT_EQ(fillets[0].y_mm, -8.25);
  EXPECT_EQ(fillets[0].angle_rad, 1.5);
  EXPECT_EQ(fillets[0].hand, Hand::kRight);
  EXPECT_EQ(fillets[0].side, SideUp::kBone);
  EXPECT_EQ(fillets[0].group_id, 0);
  EXPECT_FALSE(fillets[0].singulated);
  EXPECT_TRUE(fillets[0].fully_visible);
  EXPECT_EQ(fillets[1].x_mm, -40.0);
  EXPECT_EQ(fillets[1].group_id, std::numeric_limits<int>::max());
  std::filesystem::remove(path);
}

// The gap to the nearest fillet is written when there is one and left out when there is none
// (JSON has no infinity), and reads back either way.
TEST(RecordingTruth, GapToTheNearestFilletRoundTripsAndMayBeAbsent) {
  const auto path = temp_file("gap.mcap");
  TrueFillet near = touching_fillet(12.5, -1);
  near.singulated = true;
  near.gap_mm = 2.5;  // any gap; under the estimator's 4 mm, as the case it is written for
  TrueFillet alone = touching_fillet(-40.0, -1);
  alone.singulated = true;  // gap_mm stays infinite: no other fillet
  {
    RecordingWriter writer(path, {9, {{"source", "test"}}});
    writer.add_camera(CameraId::kOrientation, small_calibration());
    writer.write_frame(CameraId::kOrientation, kFrame, kExposureNs,
                       cv::Mat(48, 64, CV_8UC3, cv::Scalar(165, 105, 35)));
    writer.write_truth(CameraId::kOrientation, kFrame, kExposureNs, {near, alone});
    writer.close();
  }
  const Recording recording = load_recording(path);
  const std::vector<TrueFillet>& fillets =
      recording.cameras[index(CameraId::kOrientation)].truth.at(kFrame);
  ASSERT_EQ(fillets.size(), 2U);
  EXPECT_EQ(fillets[0].gap_mm, 2.5);
  EXPECT_TRUE(std::isinf(fillets[1].gap_mm));
  std::filesystem::remove(path);
}

TEST(RecordingTruth, BadGapNamesTheField) {
  expect_truth_error(message_text(fillet_with("gap_mm", "-0.5")),  // a distance is not negative
                     {"fillets[0].gap_mm: -0.5 is negative"});
  expect_truth_error(message_text(fillet_with("gap_mm", "\"3\"")),
                     {"fillets[0].gap_mm: \"3\" is not a number"});
  expect_truth_error(message_text(fillet_with("gap_mm", "null")),  // an infinity written as null
                     {"fillets[0].gap_mm: null"});
}

TEST(RecordingTruth, HandMadeMessageLikeTheWritersLoads) {
  // The hand-made messages below differ from this one in one field only: it must load.
  const auto path = temp_file("good.mcap");
  write_truth_message(path, message_text(fillet_with("x_mm", "12.5")));
  const Recording recording = load_recording(path);
  const auto& truth = recording.cameras[index(CameraId::kOrientation)].truth;
  ASSERT_EQ(truth.count(kFrame), 1U);                   // the one message
  ASSERT_EQ(truth.at(kFrame).size(), 1U);               // its one fillet
  EXPECT_EQ(truth.at(kFrame)[0].group_id, 4);           // good_fillet()'s group
  EXPECT_TRUE(std::isinf(truth.at(kFrame)[0].gap_mm));  // none given: no neighbour
  std::filesystem::remove(path);
}

TEST(RecordingTruth, NotJsonNamesTheMessageAndWhereTheTextBreaks) {
  expect_truth_error("truth", {"not JSON", "byte ", "at the top level"});
  expect_truth_error("", {"not JSON", "at the top level"});
  // A message cut short inside the first fillet, after "x_mm":12.5.
  expect_truth_error(R"({"fillets":[{"x_mm":12.5)", {"not JSON", "fillets[0].x_mm"});
}

TEST(RecordingTruth, NotAnObjectWithAFilletsArrayIsRefused) {
  expect_truth_error("[1,2]", {"not a truth message", "not an object"});  // JSON, not an object
  expect_truth_error(R"({"camera":"orientation"})", {"not a truth message", "no 'fillets'"});
  expect_truth_error(R"({"fillets":{"x_mm":1}})", {"'fillets' is not an array"});
  // A fillet that is not an object: the second item (index 1) is the number 7.
  expect_truth_error(message_text(fillet_with("x_mm", "12.5") + ",7"),
                     {"fillets[1]: 7 is not an object"});
}

TEST(RecordingTruth, FilletMissingAFieldNamesTheField) {
  for (const auto& [key, value] : good_fillet()) {
    // The bad fillet second (index 1), after a good one, so that the index is checked too.
    expect_truth_error(message_text(fillet_with("x_mm", "12.5") + "," + fillet_with(key, {})),
                       {"fillets[1]." + key + ": missing"});
  }
}

TEST(RecordingTruth, ValueOfTheWrongTypeNamesTheField) {
  expect_truth_error(message_text(fillet_with("x_mm", "\"12.5\"")),  // a number as a string
                     {"fillets[0].x_mm: \"12.5\" is not a number"});
  expect_truth_error(message_text(fillet_with("angle_rad", "true")),
                     {"fillets[0].angle_rad: true is not a number"});
  expect_truth_error(message_text(fillet_with("y_mm", "[1]")),  // 1: any number, in an array
                     {"fillets[0].y_mm: [1] is not a number"});
  expect_truth_error(message_text(fillet_with("hand", "1")),  // 1: the index of "left"
                     {"fillets[0].hand: 1 is not a string"});
  expect_truth_error(message_text(fillet_with("hand", "\"unknown\"")),
                     {"fillets[0].hand: 'unknown' is not left or right"});
  expect_truth_error(message_text(fillet_with("side", "\"up\"")),
                     {"fillets[0].side: 'up' is not skin or bone"});
  expect_truth_error(message_text(fillet_with("singulated", "1")),  // 1: true in C, not JSON
                     {"fillets[0].singulated: 1 is not true or false"});
  expect_truth_error(message_text(fillet_with("fully_visible", "\"true\"")),
                     {"fillets[0].fully_visible: \"true\" is not true or false"});
}

TEST(RecordingTruth, NonFiniteValueNamesTheField) {
  // JSON has no NaN or infinity: the writer (nlohmann::json) writes them as null.
  const auto path = temp_file("nan.mcap");
  {
    RecordingWriter writer(path, {9, {}});  // 9: the smallest file
    writer.add_camera(CameraId::kOrientation, small_calibration());
    TrueFillet fillet = touching_fillet(12.5, 0);  // 12.5, 0: any pose, any group
    fillet.y_mm = std::numeric_limits<double>::quiet_NaN();
    writer.write_truth(CameraId::kOrientation, kFrame, kExposureNs, {fillet});
    writer.close();
  }
  const std::string error = load_error(path);
  EXPECT_NE(error.find(path.string()), std::string::npos) << error;
  EXPECT_NE(error.find("/camera/orientation/truth message 3 "), std::string::npos) << error;
  EXPECT_NE(error.find("fillets[0].y_mm: null, not a number"), std::string::npos) << error;
  std::filesystem::remove(path);
  // Written by hand: null, a number beyond double's range (1e999 > 1.8e308), and the
  // JavaScript literals NaN and Infinity, which are not JSON.
  expect_truth_error(message_text(fillet_with("angle_rad", "null")),
                     {"fillets[0].angle_rad: null, not a number"});
  expect_truth_error(message_text(fillet_with("x_mm", "1e999")),
                     {"not JSON", "fillets[0].x_mm", "1e999"});
  expect_truth_error(message_text(fillet_with("x_mm", "NaN")), {"not JSON", "fillets[0].x_mm"});
  expect_truth_error(message_text(fillet_with("y_mm", "-Infinity")),
                     {"not JSON", "fillets[0].y_mm"});
}

TEST(RecordingTruth, GroupIdThatIsNotAWholeNumberInIntRangeNamesTheField) {
  // Not whole; beyond int's range either way (int max is about 2.1e9); below -1 (the "no
  // group" value); one past int max, written as an integer.
  for (const std::string group_id : {"1.5", "3e10", "-3e10", "-2", "2147483648"}) {
    expect_truth_error(
        message_text(fillet_with("group_id", group_id)),
        {"fillets[0].group_id: ", "is not -1 or a whole number from 0 to 2147483647"});
  }
  // The ends of the range load: -1 (no group) and int max, also written as a double.
  for (const std::string group_id : {"-1", "2147483647", "2.147483647e9"}) {
    SCOPED_TRACE(group_id);
    const auto path = temp_file("group_ok.mcap");
    write_truth_message(path, message_text(fillet_with("group_id", group_id)));
    EXPECT_EQ(load_error(path), "");
    std::filesystem::remove(path);
  }
}

TEST(RecordingTruth, HeaderThatDisagreesWithTheRecordIsRefused) {
  // The message says frame 4, another camera, another exposure (4 and 160 ms: frame 4's), but
  // it is recorded as frame 3's truth on the orientation camera at 120 ms.
  const std::string fillets = fillet_with("x_mm", "12.5");
  expect_truth_error(R"({"camera":"orientation","sequence":4,"fillets":[)" + fillets + "]}",
                     {"sequence: 4 in a message recorded as the truth of frame 3"});
  expect_truth_error(R"({"camera":"final","sequence":3,"fillets":[)" + fillets + "]}",
                     {"camera: \"final\" on the channel of camera orientation"});
  expect_truth_error(R"({"sequence":3,"exposure_ns":160000000,"fillets":[)" + fillets + "]}",
                     {"exposure_ns: 160000000 in a message logged at 120000000 ns"});
}

TEST(RecordingTruth, TruthOfAFrameRecordedTwiceNamesTheMessage) {
  const auto path = temp_file("twice.mcap");
  {
    RecordingWriter writer(path, {9, {}});  // 9: the smallest file
    writer.add_camera(CameraId::kOrientation, small_calibration());
    // The writer does not refuse it; the reader must.
    writer.write_truth(CameraId::kOrientation, kFrame, kExposureNs, {touching_fillet(12.5, 0)});
    writer.write_truth(CameraId::kOrientation, kFrame, kExposureNs, {touching_fillet(30.0, 0)});
    writer.close();
  }
  const std::string error = load_error(path);
  EXPECT_NE(error.find(path.string()), std::string::npos) << error;
  EXPECT_NE(error.find("/camera/orientation/truth message 3 "), std::string::npos) << error;
  EXPECT_NE(error.find("truth of a frame recorded twice"), std::string::npos) << error;
  std::filesystem::remove(path);
}

}  // namespace
}  // namespace fl::vision::record
