#include <gtest/gtest.h>

#include "core/error.h"
#include "params/yaml_params.h"

namespace stance {
namespace {

struct Inner {
  double gain = 1;
  std::vector<std::string> names;
  template <class V>
  void visit(V& v) {
    v("gain", gain, {.min = 0});
    v("names", names);
  }
};
struct Item {
  std::string body;
  double t = 0;
  template <class V>
  void visit(V& v) {
    v("body", body);
    v("t", t);
  }
};
struct Outer {
  double kp = 400;
  int count = 3;
  bool on = false;
  Eigen::Vector3d g = Eigen::Vector3d(0, 0, -9.81);
  NamedValues pose;
  Inner inner;
  std::vector<Item> items;
  template <class V>
  void visit(V& v) {
    v("kp", kp, {.unit = "N m/rad", .min = 0, .max = 1e5});
    v("count", count);
    v("on", on);
    v("g", g);
    v("pose", pose);
    v("inner", inner);
    v("items", items);
  }
};

std::string error_of(const std::string& yaml) {
  Outer o;
  try {
    YamlParamReader(YAML::Load(yaml), {"s.yaml"}).read(o);
  } catch (const InputError& e) {
    return e.what();
  }
  return "";
}

TEST(YamlParams, ReadsEveryKind) {
  Outer o;
  YamlParamReader(YAML::Load("kp: 12.5\ncount: 7\non: true\ng: [0, -9.81, 0]\n"
                             "pose: {a: 0.1, b: -2}\ninner: {gain: 3, names: [x, y]}\n"
                             "items: [{body: h, t: 1.5}, {body: k}]\n"),
                  {"s.yaml"})
      .read(o);
  EXPECT_EQ(o.kp, 12.5);
  EXPECT_EQ(o.count, 7);
  EXPECT_TRUE(o.on);
  EXPECT_EQ(o.g, Eigen::Vector3d(0, -9.81, 0));
  EXPECT_EQ(o.pose.at("b"), -2);
  EXPECT_EQ(o.inner.gain, 3);
  EXPECT_EQ(o.inner.names.size(), 2u);
  ASSERT_EQ(o.items.size(), 2u);
  EXPECT_EQ(o.items[0].t, 1.5);
  EXPECT_EQ(o.items[1].body, "k");
  EXPECT_EQ(o.items[1].t, 0);
}

TEST(YamlParams, DefaultsStayWhenAbsent) {
  Outer o;
  YamlParamReader(YAML::Load("count: 1"), {"s.yaml"}).read(o);
  EXPECT_EQ(o.kp, 400);
}

TEST(YamlParams, UnknownKeySuggestsNearestWithLine) {
  EXPECT_EQ(error_of("count: 1\nkpp: 3\n"),
            "s.yaml:2: unknown parameter 'kpp' (did you mean 'kp'?)");
  EXPECT_EQ(error_of("inner:\n  gian: 3\n"),
            "s.yaml:2: unknown parameter 'inner.gian' (did you mean 'gain'?)");
}

TEST(YamlParams, WrongTypesNameTheParameter) {
  EXPECT_EQ(error_of("kp: fast\n"), "s.yaml:1: parameter 'kp': expected a number, found 'fast'");
  EXPECT_EQ(error_of("count: 2.5\n"),
            "s.yaml:1: parameter 'count': expected an integer, found '2.5'");
  EXPECT_EQ(error_of("on: maybe\n"),
            "s.yaml:1: parameter 'on': expected true or false, found 'maybe'");
  EXPECT_EQ(error_of("g: [1, 2]\n"),
            "s.yaml:1: parameter 'g': expected a list of 3 numbers, found a list");
}

TEST(YamlParams, NonFiniteAndOutOfRangeRejected) {
  EXPECT_EQ(error_of("kp: .nan\n"),
            "s.yaml:1: parameter 'kp': must be a finite number, found '.nan'");
  EXPECT_EQ(error_of("\n\nkp: .inf\n"),
            "s.yaml:3: parameter 'kp': must be a finite number, found '.inf'");
  EXPECT_EQ(error_of("kp: -1\n"), "s.yaml:1: parameter 'kp': -1 is outside [0, 100000]");
  EXPECT_NE(error_of("pose: {a: nan}\n").find("pose.a"), std::string::npos);
}

TEST(YamlParams, OverridesReachNestedAndListEntries) {
  YAML::Node doc = YAML::Load("kp: 1\nitems: [{body: h, t: 1.5}]\n");
  apply_yaml_override(doc, "kp=250");
  apply_yaml_override(doc, "inner.gain=4");
  apply_yaml_override(doc, "items.0.t=2.5");
  apply_yaml_override(doc, "g=[1, 2, 3]");
  Outer o;
  YamlParamReader(doc, {"s.yaml"}).read(o);
  EXPECT_EQ(o.kp, 250);
  EXPECT_EQ(o.inner.gain, 4);
  EXPECT_EQ(o.items[0].t, 2.5);
  EXPECT_EQ(o.g, Eigen::Vector3d(1, 2, 3));
  // a bad override names --set
  YAML::Node doc2 = YAML::Load("kp: 1\n");
  apply_yaml_override(doc2, "kp=abc");
  try {
    YamlParamReader(doc2, {"s.yaml"}).read(o);
    FAIL();
  } catch (const InputError& e) {
    EXPECT_EQ(std::string(e.what()),
              "s.yaml: (from --set) parameter 'kp': expected a number, found 'abc'");
  }
  EXPECT_THROW(apply_yaml_override(doc2, "novalue"), InputError);
}

TEST(YamlParams, WriterRoundTrips) {
  Outer o;
  o.kp = 7;
  o.pose["x"] = 0.25;
  o.items.push_back({"b", 3});
  YAML::Node out(YAML::NodeType::Map);
  YamlParamWriter(out).write(o);
  Outer back;
  YamlParamReader(YAML::Load(YAML::Dump(out)), {"w.yaml"}).read(back);
  EXPECT_EQ(back.kp, 7);
  EXPECT_EQ(back.pose.at("x"), 0.25);
  EXPECT_EQ(back.items.at(0).t, 3);
  EXPECT_EQ(back.g, o.g);
}

TEST(YamlParams, MalformedFileNamesLine) {
  std::string path = ::testing::TempDir() + "/malformed.yaml";
  FILE* f = fopen(path.c_str(), "w");
  fputs("a: 1\nb: [1, 2\nc: 3\n", f);
  fclose(f);
  try {
    load_yaml_file(path);
    FAIL();
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("malformed.yaml:"), std::string::npos);
    EXPECT_NE(std::string(e.what()).find("malformed YAML"), std::string::npos);
  }
  EXPECT_THROW(load_yaml_file("/no/such.yaml"), InputError);
}

// a name the file system refuses (longer than NAME_MAX) is bad input naming it, not an internal
// error (fuzz_scenario: std::filesystem::exists threw)
TEST(YamlParams, AFileNameTooLongIsBadInput) {
  const std::string path = "/tmp/" + std::string(5000, 'a') + ".yaml";
  try {
    load_yaml_file(path);
    FAIL();
  } catch (const InputError& e) {
    EXPECT_EQ(std::string(e.what()), path + ": File name too long");
  }
}

// the exact message a strict load of `text` (as file "s.yaml") throws, or "" when it loads
std::string strict_error(const std::string& text) {
  try {
    load_yaml_text(text, {"s.yaml", ""});
  } catch (const InputError& e) {
    return e.what();
  }
  return "";
}

TEST(StrictYaml, DuplicateKeyNamesBothLines) {
  EXPECT_EQ(strict_error("name: a\nduration: 1\nseed: 2\nduration: 2\n"),
            "s.yaml:4: duplicate key 'duration' (first at line 2)");
  // in a nested mapping, a flow mapping, and the same key in two mappings is fine
  EXPECT_EQ(strict_error("log:\n  rate_hz: 1\n  rate_hz: 2\n"),
            "s.yaml:3: duplicate key 'rate_hz' (first at line 2)");
  EXPECT_EQ(strict_error("c: [{type: pd, kp: 1,\n     kp: 2}]\n"),
            "s.yaml:2: duplicate key 'kp' (first at line 1)");
  EXPECT_EQ(strict_error("a: {x: 1}\nb: {x: 1}\nc: [x, x]\n"), "");
  // quoting does not make another key
  EXPECT_EQ(strict_error("x: 1\n'x': 2\n"), "s.yaml:2: duplicate key 'x' (first at line 1)");
}

TEST(StrictYaml, NonScalarKeysAreLocated) {
  EXPECT_EQ(strict_error("name: a\n? [a]\n: 1\n"), "s.yaml:2: a key must be a word, found a list");
  EXPECT_EQ(strict_error("c: [{type: pd, {a: 1}: 2}]\n"),
            "s.yaml:1: a key must be a word, found a mapping");
  EXPECT_EQ(strict_error("a: 1\n~: 2\n"), "s.yaml:2: a key must be a word, found nothing");
}

TEST(StrictYaml, AliasesAreRejectedAndRecursiveOnesNamed) {
  EXPECT_EQ(strict_error("a: &g {kp: 1}\nb: *g\n"),
            "s.yaml:2: YAML aliases are not supported ('*g' repeats '&g' of line 1): write the "
            "value out");
  EXPECT_EQ(strict_error("a: &r [1, [2, *r]]\n"),
            "s.yaml:1: recursive alias '*r' inside its own anchor '&r' (line 1)");
  EXPECT_EQ(strict_error("a: &r\n  b: *r\n"),
            "s.yaml:2: recursive alias '*r' inside its own anchor '&r' (line 1)");
  EXPECT_EQ(strict_error("a: &n\nb: *n\n"),
            "s.yaml:2: YAML aliases are not supported ('*n' repeats '&n' of line 1): write the "
            "value out");
  // an anchor alone is harmless; an undefined alias is yaml-cpp's own syntax error
  EXPECT_EQ(strict_error("a: &g 1\n"), "");
  EXPECT_NE(strict_error("a: *nowhere\n").find("s.yaml:1:4: malformed YAML"), std::string::npos)
      << strict_error("a: *nowhere\n");
}

TEST(StrictYaml, OneDocumentPerFile) {
  EXPECT_EQ(strict_error("a: 1\n---\nb: 2\n"),
            "s.yaml:2: a second YAML document: a file holds one");
  EXPECT_EQ(strict_error("---\na: 1\n"), "");
}

TEST(StrictYaml, SetValuesAreCheckedToo) {
  YAML::Node root = YAML::Load("a: {b: 1}\nname: x\n");
  try {
    apply_yaml_override(root, "a={k: 1, k: 2}");
    ADD_FAILURE();
  } catch (const InputError& e) {
    EXPECT_STREQ(e.what(), "--set a={k: 1, k: 2}: duplicate key 'k' (first at line 1)");
  }
  try {
    apply_yaml_override(root, "name.x=1");
    ADD_FAILURE();
  } catch (const InputError& e) {
    EXPECT_STREQ(e.what(), "--set name.x=1: 'x' is inside a value, not a mapping");
  }
  try {
    apply_yaml_override(root, "name.x.y=1");
    ADD_FAILURE();
  } catch (const InputError& e) {
    EXPECT_STREQ(e.what(), "--set name.x.y=1: 'x' is inside a value, not a mapping");
  }
}

TEST(StrictYaml, FilesGoThroughIt) {
  std::string path = ::testing::TempDir() + "/dup.yaml";
  FILE* f = fopen(path.c_str(), "w");
  fputs("a: 1\nb: 2\na: 3\n", f);
  fclose(f);
  try {
    load_yaml_file(path);
    FAIL();
  } catch (const InputError& e) {
    EXPECT_EQ(std::string(e.what()), path + ":3: duplicate key 'a' (first at line 1)");
  }
}

// the exact message apply_yaml_override throws for `assignment` on the document `yaml`
std::string set_error(const std::string& yaml, const std::string& assignment) {
  YAML::Node root = YAML::Load(yaml);
  try {
    apply_yaml_override(root, assignment);
  } catch (const InputError& e) {
    return e.what();
  }
  return "";
}

// an empty name read as index 0 or as the key '' (controllers..kp set controllers[0].kp)
TEST(YamlOverride, AnEmptyNameInThePathIsAnError) {
  const std::string doc = "duration: 1\ncontrollers: [{type: pd, kp: 1}]\n";
  EXPECT_EQ(set_error(doc, "controllers..kp=1"),
            "--set controllers..kp=1: an empty name in 'controllers..kp' (two dots in a row)");
  EXPECT_EQ(set_error(doc, ".duration=0.5"),
            "--set .duration=0.5: an empty name in '.duration' (a dot at its start)");
  EXPECT_EQ(set_error(doc, "duration.=5"),
            "--set duration.=5: an empty name in 'duration.' (a dot at its end)");
  // an index is digits only
  EXPECT_EQ(set_error(doc, "controllers.+0.kp=1"),
            "--set controllers.+0.kp=1: '+0' is not an index of a list of 1");
  EXPECT_EQ(set_error(doc, "controllers.0.kp=2"), "");
}

TEST(YamlOverride, AnIndexIntoAListTheDocumentLacksSaysSo) {
  EXPECT_EQ(set_error("duration: 1\n", "perturbations.3.start=1"),
            "--set perturbations.3.start=1: the scenario has no 'perturbations', so index 3 is "
            "past the end of an empty list");
  EXPECT_EQ(set_error("a: {b: 1}\nc:\n", "c.0=1"),
            "--set c.0=1: the scenario has no 'c', so index 0 is past the end of an empty list");
  EXPECT_EQ(set_error("a: {b: 1}\n", "a.x.2.y=1"),
            "--set a.x.2.y=1: the scenario has no 'a.x', so index 2 is past the end of an empty "
            "list");
  // a new key in a mapping is still made
  EXPECT_EQ(set_error("duration: 1\n", "log.rate_hz=5"), "");
}

// yaml-cpp read "[0,0" as a list used as a key
TEST(YamlOverride, AnUnclosedBracketInTheValueIsNamed) {
  const std::string doc = "gravity: [0, 0, -9.81]\nname: x\n";
  EXPECT_EQ(set_error(doc, "gravity=[0,0"), "--set gravity=[0,0: the value has an unclosed '['");
  EXPECT_EQ(set_error(doc, "gravity={a: [1, 2}"),
            "--set gravity={a: [1, 2}: the value's '[' is closed by '}'");
  EXPECT_EQ(set_error(doc, "gravity=[[0, 0], 1"),
            "--set gravity=[[0, 0], 1: the value has an unclosed '['");
  // brackets inside quotes and inside plain words are text
  EXPECT_EQ(set_error(doc, "gravity=['a]', \"b[\", it's]"), "");
  EXPECT_EQ(set_error(doc, "name=a[1"), "");
}

TEST(YamlOverride, BytesThatAreNotUtf8AreNamedAndEscaped) {
  // yaml-cpp read FF FE as a UTF-16 byte order mark: "expected a string, found nothing"
  EXPECT_EQ(set_error("name: x\n", "name=\xFF\xFE"),
            "--set name=\\xFF\\xFE: not UTF-8 text (byte 0xFF at character 6)");
  EXPECT_EQ(set_error("name: x\n", "na\xC3me=1"),
            "--set na\\xC3me=1: not UTF-8 text (byte 0xC3 at character 3)");
}

TEST(YamlOverride, NestingAndPathsAreBounded) {
  EXPECT_EQ(set_error("a: 1\n", "a=" + std::string(100, '[') + std::string(100, ']')),
            "--set a=" + std::string(100, '[') + std::string(100, ']') +
                ": lists and mappings nested more than 64 deep");
  std::string path = "a";
  for (int i = 0; i < 99; ++i) path += ".a";
  EXPECT_EQ(set_error("a: 1\n", path + "=1"),
            "--set " + path + "=1: a path of 100 names (at most 64)");
}

TEST(StrictYaml, NestingIsBoundedBeforeYamlCppRecurses) {
  // yaml-cpp said "malformed YAML: bad file" at 2,000 levels, with the column of the line's end
  for (int depth : {65, 3000, 100000})
    EXPECT_EQ(strict_error("a: " + std::string(depth, '[') + std::string(depth, ']') + "\n"),
              "s.yaml:1: lists and mappings nested more than 64 deep")
        << depth;
  EXPECT_EQ(strict_error(std::string(64, '[') + std::string(64, ']') + "\n"), "");
  std::string dashes;
  for (int i = 0; i < 100000; ++i) dashes += "- ";
  EXPECT_EQ(strict_error(dashes + "1\n"), "s.yaml:1: lists and mappings nested more than 64 deep");
  std::string block = "x:\n";
  for (int i = 1; i <= 100; ++i) block += std::string(i, ' ') + "a:\n";
  EXPECT_EQ(strict_error(block), "s.yaml:65: lists and mappings nested more than 64 deep");
}

TEST(StrictYaml, TextThatIsNotUtf8IsRefusedWithItsLine) {
  using namespace std::string_literals;
  // yaml-cpp: "bad character found while scanning hex number"
  EXPECT_EQ(strict_error("name: t\nduration: 1\0\n"s), "s.yaml:2: a NUL byte at column 12");
  // passed on, to fail in summary.json's writer after log.csv was written
  EXPECT_EQ(strict_error("duration: 1\nname: \"a\xFF\xFE\"\n"),
            "s.yaml:2: not UTF-8 text (byte 0xFF at column 9)");
  EXPECT_EQ(strict_error("# caf\xE9\nname: x\n"),
            "s.yaml:1: not UTF-8 text (byte 0xE9 at column 6)");
  EXPECT_EQ(strict_error("\xFF\xFE"
                         "n\0a\0m\0e\0"s),
            "s.yaml: UTF-16 text (byte order mark FF FE): save it as UTF-8");
  EXPECT_EQ(strict_error("\xEF\xBB\xBF"
                         "name: x\n"),
            "");
}

// the strict checks' findings wait for yaml-cpp's syntax errors: an unclosed '[' is one, not a
// list used as a key
TEST(StrictYaml, ASyntaxErrorWinsOverAStrictFinding) {
  EXPECT_EQ(strict_error("a: [0,0"), "s.yaml:1:1: malformed YAML: end of sequence flow not found");
  EXPECT_EQ(strict_error("[0,0"), "s.yaml:1:1: malformed YAML: end of sequence flow not found");
}

// strings reach summary.json, whose writer needs UTF-8: a node made in code is checked too
TEST(YamlParams, StringsMustBeUtf8) {
  YAML::Node doc;
  doc["items"].push_back(YAML::Node(YAML::NodeType::Map));
  doc["items"][0]["body"] = "h\xFF";
  doc["inner"]["names"].push_back("ok");
  doc["inner"]["names"].push_back("\xC3(");
  Outer o;
  try {
    YamlParamReader(doc, {"s.yaml"}).read(o);
    FAIL();
  } catch (const InputError& e) {
    EXPECT_STREQ(e.what(),
                 "s.yaml: (from --set) parameter 'inner.names[1]': not UTF-8 text (byte 0xC3 at "
                 "character 1)");
  }
  doc.remove("inner");
  try {
    YamlParamReader(doc, {"s.yaml"}).read(o);
    FAIL();
  } catch (const InputError& e) {
    EXPECT_STREQ(e.what(),
                 "s.yaml: (from --set) parameter 'items[0].body': not UTF-8 text (byte 0xFF at "
                 "character 2)");
  }
}

}  // namespace
}  // namespace stance
