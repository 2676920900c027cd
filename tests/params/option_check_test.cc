#include "params/option_check.h"

#include <gtest/gtest.h>

#include <limits>

namespace stance {
namespace {

struct OptionLogParams {
  double rate_hz = 100;
  template <class V>
  void visit(V& v) {
    v("rate_hz", rate_hz, {.unit = "Hz", .min = 0.001, .max = 1e6});
  }
};
struct OptionRunParams {
  double duration = 10;
  int threads = 0;
  OptionLogParams log;
  template <class V>
  void visit(V& v) {
    v("duration", duration, {.unit = "s", .min = 0});
    v("threads", threads, {.min = 0, .max = 1024});
    v("log", log);
  }
};

TEST(OptionCheck, FindsTheRangeAVisitDeclares) {
  EXPECT_EQ(param_meta<OptionRunParams>("duration").min, 0);
  EXPECT_EQ(param_meta<OptionRunParams>("duration").unit, "s");
  EXPECT_EQ(param_meta<OptionRunParams>("threads").max, 1024);
  EXPECT_EQ(param_meta<OptionRunParams>("log.rate_hz").min, 0.001);
  EXPECT_THROW(param_meta<OptionRunParams>("log.rate"), std::logic_error);
  EXPECT_THROW(param_meta<OptionRunParams>("lo"), std::logic_error);
}

std::string option_error(double value, const ParamMeta& meta) {
  try {
    check_option_number("--duration", value, meta);
  } catch (const InputError& e) {
    return e.what();
  }
  return "";
}

// `stance run --duration nan`, `-1` and `inf` ran 0 steps and exited 0
TEST(OptionCheck, RefusesWhatTheYamlRefuses) {
  const ParamMeta duration = param_meta<OptionRunParams>("duration");
  EXPECT_EQ(option_error(std::numeric_limits<double>::quiet_NaN(), duration),
            "--duration: must be a finite number, found nan");
  EXPECT_EQ(option_error(std::numeric_limits<double>::infinity(), duration),
            "--duration: must be a finite number, found inf");
  EXPECT_EQ(option_error(-1, duration), "--duration: -1 is outside [0, inf]");
  EXPECT_EQ(option_error(0, duration), "");
  EXPECT_EQ(option_error(2.5, duration), "");
  EXPECT_EQ(option_error(2000, param_meta<OptionRunParams>("threads")),
            "--duration: 2000 is outside [0, 1024]");
  EXPECT_NO_THROW(check_option_number("--duration", std::optional<double>(), duration));
}

}  // namespace
}  // namespace stance
