// The JSON timeline parser (src/timeline.hpp) against the tiny package: any
// text is either refused with an ardy::Error or parsed into constraints that
// validate, and timeline_to_json of a parsed timeline reads back as a
// timeline of the same size (the header's promise). The parsed constraints
// are then rasterized into the denoiser's goals (window_goals) at the window
// each constraint starts in, with and without root interpolation and the
// root speed limit: the goals must be finite.

#include <cstddef>
#include <cstdint>
#include <memory>
#include <cmath>
#include <string>

#include <nlohmann/json.hpp>

#include "fuzz_common.hpp"
#include "package.hpp"
#include "constraints.hpp"
#include "timeline.hpp"

namespace {

const ardy::ModelPackage& package() {
  static const std::unique_ptr<ardy::ModelPackage> p = [] {
    ardy::PackageOptions options;
    options.session.intra_op_threads = 1;
    return std::make_unique<ardy::ModelPackage>(
        ardy::ModelPackage::from_folder(ardy_fuzz::data_path("tiny_package"), options));
  }();
  return *p;
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const std::string text(reinterpret_cast<const char*>(data), size);
  ardy::Timeline timeline;
  try {
    timeline = ardy::parse_timeline_text(text, package(), "fuzz.json");
  } catch (const ardy::Error&) {
    return 0;
  }
  try {
    const std::string written = ardy::timeline_to_json(timeline, package()).dump();
    const ardy::Timeline again = ardy::parse_timeline_text(written, package(), "written");
    if (again.prompts.size() != timeline.prompts.size() || again.constraints.size() != timeline.constraints.size()) {
      ardy_fuzz::broken("timeline_to_json read back with other sizes: " + written.substr(0, 400));
    }
  } catch (const ardy::Error& e) {
    ardy_fuzz::broken(std::string("timeline_to_json of a parsed timeline is refused: ") + e.what());
  }
  const ardy::ModelPackage& p = package();
  ardy::GoalSpec spec;
  spec.layout = &p.layout();
  spec.normalization = &p.feature_normalization();
  spec.patch = p.tokens().patch;
  spec.window_tokens = p.tokens().window;
  spec.future_limit_tokens = p.tokens().max_future;
  spec.fps = p.fps();
  const bool interpolate = size % 2 == 0;
  spec.interpolate_root = interpolate;
  spec.max_root_speed = interpolate ? ardy::kDefaultMaxRootSpeed : 0.0;
  std::vector<int64_t> starts{0};
  for (const ardy::Constraint& c : timeline.constraints) {
    if (starts.size() < 4) starts.push_back(ardy::constraint_frames(c).first);
  }
  for (const int64_t start : starts) {
    try {
      const ardy::WindowGoals goals = ardy::window_goals(timeline.constraints, start, glm::dvec2(0.0), spec);
      for (float v : goals.window_goal) {
        if (!std::isfinite(v)) ardy_fuzz::broken("a non-finite window goal from validated constraints");
      }
      for (float v : goals.future_goal) {
        if (!std::isfinite(v)) ardy_fuzz::broken("a non-finite future goal from validated constraints");
      }
    } catch (const ardy::Error& e) {
      ardy_fuzz::broken(std::string("window_goals refused validated constraints: ") + e.what());
    }
  }
  return 0;
}
