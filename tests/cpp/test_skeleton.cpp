// Skeleton: validation on construction and lookups with errors that name the joint.

#include <catch_amalgamated.hpp>

#include <cmath>
#include <limits>
#include <string>
#include <vector>

#include "skeleton.hpp"
#include "support/error_message.hpp"
#include "support/skeletons.hpp"

using ardy::Skeleton;
using ardy_test::error_message;
using Catch::Matchers::ContainsSubstring;

TEST_CASE("a valid skeleton answers lookups", "[skeleton]") {
  const Skeleton s = ardy_test::ardy_test_skeleton();
  CHECK(s.joint_count() == 21);
  CHECK(s.name(0) == "Hips");
  CHECK(s.parent(0) == -1);
  CHECK(s.parent(16) == 15);
  CHECK(s.offset(14) == glm::vec3(0, -0.4f, 0));
  CHECK(s.index_of("Toes_R") == 20);
  CHECK(s.find("Head") == std::optional<size_t>(4));
  CHECK_FALSE(s.find("head").has_value());  // exact names
  CHECK(s.indices_of({"Foot_L", "Toes_L", "Foot_R", "Toes_R"}) == std::vector<size_t>{15, 16, 19, 20});
  CHECK(s.children(0) == std::vector<size_t>{1, 13, 17});
  CHECK(s.children(2) == std::vector<size_t>{3, 5, 9});
  CHECK(s.children(20).empty());
  const Skeleton single({"only"}, {-1}, {{0, 0, 0}});
  CHECK(single.joint_count() == 1);
}

TEST_CASE("unknown joints and bad indices are named in the error", "[skeleton]") {
  const Skeleton s = ardy_test::ardy_test_skeleton();
  const std::string message = error_message([&] { s.index_of("Hand"); });
  CHECK_THAT(message, ContainsSubstring("skeleton: unknown joint 'Hand'") &&
                          ContainsSubstring("Hips, Spine, Chest") && ContainsSubstring("Toes_R"));
  CHECK_THAT(error_message([&] { s.indices_of({"Foot_L", "Tail"}); }), ContainsSubstring("unknown joint 'Tail'"));
  CHECK_THAT(error_message([&] { s.name(21); }), ContainsSubstring("joint index 21 out of range (the skeleton has 21"));
  CHECK_THAT(error_message([&] { s.children(99); }), ContainsSubstring("joint index 99 out of range"));
}

TEST_CASE("invalid hierarchies are refused naming the joint", "[skeleton]") {
  const glm::vec3 o(0, 1, 0);
  CHECK_THAT(error_message([&] { Skeleton({}, {}, {}); }), ContainsSubstring("skeleton: no joints"));
  CHECK_THAT(error_message([&] { Skeleton({"a", "b"}, {-1}, {o, o}); }),
             ContainsSubstring("2 joint names, 1 parents and 2 offsets"));
  CHECK_THAT(error_message([&] { Skeleton({"a", "b", "c"}, {-1, 2, 0}, {o, o, o}); }),
             ContainsSubstring("joint 1 ('b') has parent 2; a parent must be an earlier joint"));
  CHECK_THAT(error_message([&] { Skeleton({"a", "b"}, {-1, 1}, {o, o}); }),
             ContainsSubstring("joint 1 ('b') has parent 1"));
  CHECK_THAT(error_message([&] { Skeleton({"a", "b"}, {-1, -1}, {o, o}); }),
             ContainsSubstring("joint 1 ('b') has parent -1") && ContainsSubstring("only joint 0 may be the root"));
  CHECK_THAT(error_message([&] { Skeleton({"a", "b"}, {0, -1}, {o, o}); }),
             ContainsSubstring("joint 0 ('a') must be the root (parent -1), found parent 0"));
  CHECK_THAT(error_message([&] { Skeleton({"a", "b", "a"}, {-1, 0, 1}, {o, o, o}); }),
             ContainsSubstring("joint name 'a' appears twice (joints 0 and 2)"));
  CHECK_THAT(error_message([&] { Skeleton({"a", ""}, {-1, 0}, {o, o}); }),
             ContainsSubstring("joint 1 has an empty name"));
  const float nan = std::numeric_limits<float>::quiet_NaN();
  CHECK_THAT(error_message([&] { Skeleton({"a", "b"}, {-1, 0}, {o, {0, nan, 0}}); }),
             ContainsSubstring("rest offset of joint 1 ('b') is not finite"));
  const float inf = std::numeric_limits<float>::infinity();
  CHECK_THAT(error_message([&] { Skeleton({"a"}, {-1}, {{inf, 0, 0}}); }), ContainsSubstring("not finite"));
}
