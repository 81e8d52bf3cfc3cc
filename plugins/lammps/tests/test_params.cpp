// The parameter reader: the example file loads, each kind of bad input is rejected with a
// one-line message naming the field, and every bad document of the corpus
// tests/data/bad-law-params/ (generated from the schema by geocontact.law.bad_documents) gives
// exactly the message the Python loader gives.
#include "geocontact/params.hpp"

#include <cmath>
#include <cstdio>
#include <string>

namespace {

int failures = 0;

void expect_error(const std::string &text, const std::string &needle, const char *what)
{
  try {
    geocontact::parse_params(text, "test.json");
    std::fprintf(stderr, "FAIL %s: accepted\n", what);
    ++failures;
  } catch (const geocontact::InputError &e) {
    const std::string msg = e.what();
    if (msg.find(needle) == std::string::npos || msg.find('\n') != std::string::npos) {
      std::fprintf(stderr, "FAIL %s: message '%s' lacks '%s'\n", what, msg.c_str(),
                   needle.c_str());
      ++failures;
    }
  }
}

std::string replace(std::string text, const std::string &from, const std::string &to)
{
  const size_t at = text.find(from);
  if (at == std::string::npos) {
    std::fprintf(stderr, "FAIL: test fixture lacks '%s'\n", from.c_str());
    ++failures;
    return text;
  }
  return text.replace(at, from.size(), to);
}

// Every case of the corpus index: the C++ reader's message equals the Python loader's.
int replay_corpus(const std::string &dir)
{
  const geocontact::json::Value index =
      geocontact::json::parse(geocontact::read_text_file(dir + "/index.json"), "index.json");
  int cases = 0;
  for (const geocontact::json::Value &c : index.find("cases")->array) {
    const std::string file = dir + "/" + c.find("file")->string;
    const std::string expected = c.find("message")->string;
    ++cases;
    try {
      geocontact::load_params(file);
      std::fprintf(stderr, "FAIL %s: accepted\n", file.c_str());
      ++failures;
    } catch (const geocontact::InputError &e) {
      if (expected != e.what()) {
        std::fprintf(stderr, "FAIL %s:\n  C++:    %s\n  Python: %s\n", file.c_str(), e.what(),
                     expected.c_str());
        ++failures;
      }
    }
  }
  geocontact::load_params(dir + "/base.json");  // the document every case changes is valid
  geocontact::load_params(dir + "/base-table.json");  // and the one of the table's cases
  geocontact::load_params(dir + "/base-segments.json");  // and the one of the segments' cases
  return cases;
}

}  // namespace

int main(int argc, char **argv)
{
  if (argc != 3) {
    std::fprintf(stderr, "usage: test_params GOOD.json BAD_DOCUMENTS_DIR\n");
    return 2;
  }
  const std::string good = geocontact::read_text_file(argv[1]);
  const geocontact::LawParams p = geocontact::parse_params(good, argv[1]);
  if (!(p.yield_approach > 0.0 && p.hertz_coefficient > 0.0 && p.material.radius == 0.1)) {
    std::fprintf(stderr, "FAIL: example parameters not read\n");
    ++failures;
  }
  // Kh = (4/3) E* sqrt(R*) for two identical spheres
  const double es = 1e10 / (2.0 * (1.0 - 0.0625));
  if (std::fabs(p.hertz_coefficient - 4.0 / 3.0 * es * std::sqrt(0.05)) >
      1e-12 * p.hertz_coefficient) {
    std::fprintf(stderr, "FAIL: Hertz coefficient\n");
    ++failures;
  }
  try {
    geocontact::load_params("/nonexistent/P.json");
    ++failures;
  } catch (const geocontact::InputError &e) {
    if (std::string(e.what()).find("not found") == std::string::npos) ++failures;
  }
  expect_error("{\"schema\": ", "malformed JSON", "truncated JSON");
  expect_error("[1, 2]", "params: must hold a JSON object", "not an object");
  expect_error(good + "x", "unexpected text", "trailing text");
  expect_error(replace(good, "geocontact.law/1", "geocontact.law/9"), "schema", "schema");
  expect_error(replace(good, "\"youngs_modulus\": 10000000000.0", "\"youngs_modulus\": -1"),
               "material.youngs_modulus: must be in", "negative modulus");
  expect_error(replace(good, "\"poissons_ratio\": 0.25", "\"poissons_ratio\": \"a\""),
               "material.poissons_ratio: expected a number", "string for number");
  expect_error(replace(good, "\"radius\": 0.1", "\"radius_m\": 0.1"), "material.radius_m",
               "unknown material key");
  expect_error(replace(good, "\"limit\": 0.9", "\"limit\": 1.0"), "residual_approach.limit",
               "residual limit out of range");
  expect_error(replace(good, "\"approach_m\": 1.44", "\"approach_m\": 2.44"),
               "yield.force_N", "yield force disagrees");
  expect_error(replace(good, "\"elastic_plastic_exponent\": 1.3", "\"elastic_plastic_exponent\": 2.9"),
               "creates energy", "energy check");
  expect_error(replace(good, "\"unloading\"", "\"unloadin\""), "unloadin: unknown key",
               "misspelt section");
  expect_error(replace(good, "\"enabled\": false", "\"enabled\": 0"), "cyclic.enabled",
               "cyclic flag type");
  // c N^-p applies from cycle 2: c > 1 is allowed while c 2^-p <= 1
  const geocontact::LawParams steep = geocontact::parse_params(
      replace(good, "\"coefficient\": 0.3,\n      \"power\": 1.4", "\"coefficient\": 2.34,\n      \"power\": 4.5"),
      "steep");
  if (steep.cyclic.residual_ratio_coefficient != 2.34) {
    std::fprintf(stderr, "FAIL: cyclic coefficient > 1 with a steep power not read\n");
    ++failures;
  }
  expect_error(replace(good, "\"coefficient\": 0.3,", "\"coefficient\": 3.0,"),
               "cyclic.residual_ratio: the cycle-2 ratio", "cycle-2 ratio above 1");
  // a folder and the literals NaN/Infinity get the Python loader's messages
  // (files.read_text_input; law.params.non_finite_literal)
  try {
    geocontact::load_params(argv[2]);
    ++failures;
  } catch (const geocontact::InputError &e) {
    if (std::string(e.what()) != "params: " + std::string(argv[2]) +
                                     " is a directory, expected a file") {
      std::fprintf(stderr, "FAIL folder: %s\n", e.what());
      ++failures;
    }
  }
  expect_error(replace(good, "\"limit\": 0.9", "\"limit\": NaN"), "malformed JSON in test.json: NaN at line",
               "NaN literal");
  expect_error(replace(good, "\"limit\": 0.9", "\"limit\": -Infinity"), ": -Infinity at line",
               "-Infinity literal");
  geocontact::parse_params(replace(good, "\"label\": \"", "\"label\": \"NaN, Infinity: "),
                           "literals in a string");
  const int cases = replay_corpus(argv[2]);
  std::printf("params: %d bad documents replayed, %d failures\n", cases, failures);
  return failures == 0 ? 0 : 1;
}
