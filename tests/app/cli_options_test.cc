// A command's options struct, visited once, as CLI11 options (app/cli_options.h) and as
// documentation (params/param_doc.h): names, flags, lists, positionals and defaults.
#include "app/cli_options.h"

#include <gtest/gtest.h>

#include <optional>
#include <string>
#include <vector>

#include "app/commands.h"
#include "params/param_doc.h"

namespace stance {
namespace {

struct ExampleCommand {
  std::string scenario;
  std::optional<double> duration;
  int max_steps = 3;
  double push_duration = 0.2;
  std::vector<std::string> sets;
  bool plot = true;
  bool quiet = false;

  template <class V>
  void visit(V& v) {
    v("scenario", scenario, {.help = "scenario YAML", .names = "scenario", .required = true});
    v("duration", duration, {.help = "simulated seconds", .unit = "s", .min = 0});
    v("max_steps", max_steps, {.help = "steps allowed"});
    v("push_duration", push_duration, {.help = "push, s", .names = "--push,--duration-push"});
    v("sets", sets, {.help = "override", .names = "--set"});
    v("plot", plot, {.help = "plot", .names = "--plot,!--no-plot"});
    v("quiet", quiet, {.help = "no lines"});
  }
};

// parses words (the program name first) into a fresh command; throws CLI11's parse errors
ExampleCommand parse(std::vector<std::string> words) {
  CLI::App app;
  ExampleCommand command;
  add_cli_options(app, command);
  std::vector<char*> argv = {const_cast<char*>("stance")};
  for (auto& w : words) argv.push_back(w.data());
  app.parse(static_cast<int>(argv.size()), argv.data());
  return command;
}

TEST(CliOptions, FieldsKeepTheirDefaultsUnlessGiven) {
  const ExampleCommand c = parse({"s.yaml"});
  EXPECT_EQ(c.scenario, "s.yaml");
  EXPECT_FALSE(c.duration);
  EXPECT_EQ(c.max_steps, 3);
  EXPECT_EQ(c.push_duration, 0.2);
  EXPECT_TRUE(c.sets.empty());
  EXPECT_TRUE(c.plot);
  EXPECT_FALSE(c.quiet);
}

TEST(CliOptions, NamesComeFromTheKeyOrTheMeta) {
  const ExampleCommand c =
      parse({"--max-steps", "5", "--duration", "1.5", "--duration-push", "0.3", "--no-plot",
             "--quiet", "--set", "a=1", "--set", "b=2", "s.yaml"});
  EXPECT_EQ(c.max_steps, 5);
  EXPECT_EQ(c.duration, 1.5);
  EXPECT_EQ(c.push_duration, 0.3);
  EXPECT_FALSE(c.plot);
  EXPECT_TRUE(c.quiet);
  EXPECT_EQ(c.sets, (std::vector<std::string>{"a=1", "b=2"}));
  EXPECT_EQ(parse({"s.yaml", "--push", "0.4"}).push_duration, 0.4);
}

TEST(CliOptions, BadCommandLinesAreRefused) {
  EXPECT_THROW(parse({}), CLI::RequiredError);                               // no scenario
  EXPECT_THROW(parse({"s.yaml", "--set", "a=1", "b=2"}), CLI::ExtrasError);  // one per --set
  EXPECT_THROW(parse({"s.yaml", "--max_steps", "5"}), CLI::ExtrasError);     // '_' is '-'
  EXPECT_THROW(parse({"s.yaml", "--max-steps", "five"}), CLI::ConversionError);
}

// the same visit documents a command: its fields' defaults, units and help
TEST(CliOptions, TheVisitAlsoDocumentsTheCommand) {
  const std::vector<ParamDoc> docs = document_params<BvhRetargetCommand>();
  ASSERT_GE(docs.size(), 9u);
  EXPECT_EQ(docs[0].path, "bvh");
  EXPECT_EQ(docs[0].meta.help, "BVH file");
  EXPECT_EQ(docs[4].path, "engine");
  EXPECT_EQ(docs[4].default_value, "mujoco");
  EXPECT_EQ(docs[6].path, "duration_s");
  EXPECT_EQ(docs[6].meta.unit, "s");
  EXPECT_EQ(range_text(docs[6].meta), ">= 0");
  EXPECT_EQ(docs[8].default_value, "-1");
}

}  // namespace
}  // namespace stance
