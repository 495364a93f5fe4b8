// Session files are read like robot files: syntax errors and semantic errors found later both name
// file, line and column.
#include "proto/session_file.h"

#include <gtest/gtest.h>

#include <stdexcept>
#include <string>

#include "proto/robot_file.h"

namespace doppel::proto {
namespace {

std::string error_of(std::string_view text) {
  try {
    SessionFile::parse(text, "s.textproto");
  } catch (const std::runtime_error& e) {
    return e.what();
  }
  return "no error";
}

TEST(SessionFile, CamerasAndTheirFieldsAreLocated) {
  const SessionFile sut = SessionFile::parse(
      "# comment\ncamera {\n  name: \"TV\"\n  pose { position_m { y: -3 } }\n}\ncamera { name: \"B\" }\n",
      "s.textproto");

  ASSERT_EQ(sut.session().camera_size(), 2);
  EXPECT_EQ(sut.session().camera(0).name(), "TV");
  EXPECT_DOUBLE_EQ(sut.session().camera(0).pose().position_m().y(), -3.0);
  EXPECT_EQ(sut.location(sut.session(), "camera", 1), "s.textproto:6:1");
  EXPECT_EQ(sut.location(sut.session().camera(0), "name"), "s.textproto:3:3");
  EXPECT_EQ(sut.location(sut.session().camera(0).pose(), "position_m"), "s.textproto:4:10");
  // A field not written falls back to its message's position.
  EXPECT_EQ(sut.location(sut.session().camera(1), "pose"), "s.textproto:6:1");
}

TEST(SessionFile, FailNamesLocationTypeAndField) {
  const SessionFile sut = SessionFile::parse("camera {\n  fps: -1\n}\n", "s.textproto");

  try {
    sut.fail(sut.session().camera(0), "fps", -1, "must be positive");
    FAIL() << "no exception";
  } catch (const std::invalid_argument& e) {
    EXPECT_STREQ(e.what(), "s.textproto:2:3: WorldCamera.fps: must be positive");
  }
}

TEST(SessionFile, SyntaxErrorsAndUnreadableFilesNameTheFile) {
  EXPECT_EQ(error_of("camera {\n  name: \"A\"\n  zoom: 2\n}\n").rfind("s.textproto:3:", 0), 0u)
      << error_of("camera {\n  name: \"A\"\n  zoom: 2\n}\n");
  EXPECT_EQ(error_of("camera { name: \"A\"").rfind("s.textproto:1:", 0), 0u) << error_of("camera { name: \"A\"");
  try {
    SessionFile::load("/nonexistent/s.textproto");
    FAIL() << "no exception";
  } catch (const std::runtime_error& e) {
    EXPECT_STREQ(e.what(), "/nonexistent/s.textproto: cannot read session file: No such file or directory");
  }
}

TEST(SessionFile, RobotFilesKeepTheirOwnType) {
  const RobotFile sut = RobotFile::parse("name: \"r\"\nbus { name: \"body\" }\n", "r.textproto");

  EXPECT_EQ(sut.description().name(), "r");
  EXPECT_EQ(sut.location(sut.description().bus(0), "name"), "r.textproto:2:7");
  EXPECT_THROW(SessionFile::parse("name: \"r\"\n", "r.textproto"), std::runtime_error);  // not a session
}

}  // namespace
}  // namespace doppel::proto
