// geocontact: read and validate a `geocontact.law/1` parameter file into LawParams.
// Every field is checked against the schema src/geocontact/data/law-schema.json, embedded at
// build time as geocontact/law_schema.hpp (plugins/lammps/cmake/law_schema.cmake), the table the
// Python loader (geocontact.schema) reads too: the same ranges and one-line messages. The rules
// between fields are code here as in geocontact.law.params; tests/data/bad-law-params/ holds
// both to the same messages.
#ifndef GEOCONTACT_PARAMS_HPP
#define GEOCONTACT_PARAMS_HPP

#include "geocontact/json.hpp"
#include "geocontact/law.hpp"
#include "geocontact/law_schema.hpp"

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <limits>
#include <map>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

namespace geocontact {

namespace detail {

inline std::string format_g(double value)
{
  char buf[64];
  std::snprintf(buf, sizeof(buf), "%g", value);
  return buf;
}

// --- the schema --------------------------------------------------------------------------
inline const std::vector<const json::Value *> &schema_fields()
{
  static const json::Value schema = json::parse(kLawSchemaJson, "law-schema.json");
  static const std::vector<const json::Value *> fields = [] {
    std::vector<const json::Value *> out;
    for (const json::Value &f : schema.find("fields")->array) out.push_back(&f);
    return out;
  }();
  return fields;
}

inline std::string text_of(const json::Value &spec, const char *key)
{
  const json::Value *v = spec.find(key);
  return v && v->kind == json::Value::STRING ? v->string : std::string();
}

inline bool has(const json::Value &spec, const char *key) { return spec.find(key) != nullptr; }

inline std::string last_part(const std::string &path)
{
  const size_t dot = path.rfind('.');
  return dot == std::string::npos ? path : path.substr(dot + 1);
}

// The fields one level below `path` ("" for the document), in schema order.
inline std::vector<const json::Value *> children(const std::string &path)
{
  std::vector<const json::Value *> out;
  for (const json::Value *f : schema_fields()) {
    const std::string p = text_of(*f, "path");
    const size_t dot = p.rfind('.');
    const std::string parent = dot == std::string::npos ? std::string() : p.substr(0, dot);
    if (parent == path) out.push_back(f);
  }
  return out;
}

inline const json::Value *schema_field(const std::string &path)
{
  for (const json::Value *f : schema_fields())
    if (text_of(*f, "path") == path) return f;
  return nullptr;
}

// The validated values by path: given, or the schema's default.
struct Values {
  std::map<std::string, double> numbers;
  std::map<std::string, bool> bools;
  std::map<std::string, std::string> strings;
  std::map<std::string, std::vector<double>> arrays;
};

inline double default_number(const json::Value &spec)
{
  const json::Value *d = spec.find("default");
  if (d->kind == json::Value::STRING && d->string == "inf")
    return std::numeric_limits<double>::infinity();
  return d->number;
}

// A short printable-ASCII string quoted, else its length in characters (as geocontact.schema).
inline std::string short_string(const std::string &text)
{
  size_t characters = 0;
  bool plain = true;
  for (unsigned char c : text) {
    if ((c & 0xC0) != 0x80) ++characters;
    plain = plain && c >= ' ' && c <= '~' && c != '"' && c != '\\';
  }
  if (plain && characters <= 40) return "\"" + text + "\"";
  return "a string of " + std::to_string(characters) + " characters";
}

inline std::string bound_text(const json::Value *v, double scale, const char *none)
{
  return v ? format_g(v->number * scale) : std::string(none);
}

// A finite number inside the field's range (times `scale`, the relative_to field's value).
inline double check_number(const std::string &where, const json::Value &value,
                           const json::Value &spec, double scale)
{
  if (value.kind != json::Value::NUMBER)
    throw InputError(where + ": expected a number, got " + json::kind_name(value.kind));
  const double x = value.number;
  if (!std::isfinite(x))
    throw InputError(where + ": must be a finite number, got " + (x > 0 ? "inf" : "-inf"));
  const json::Value *lo_open = spec.find("exclusiveMinimum");
  const json::Value *hi_open = spec.find("exclusiveMaximum");
  const json::Value *lo = lo_open ? lo_open : spec.find("minimum");
  const json::Value *hi = hi_open ? hi_open : spec.find("maximum");
  const bool bad_lo = lo && (lo_open ? x <= lo->number * scale : x < lo->number * scale);
  const bool bad_hi = hi && (hi_open ? x >= hi->number * scale : x > hi->number * scale);
  if (bad_lo || bad_hi) {
    std::string unit = has(spec, "unit") ? " " + text_of(spec, "unit") : std::string();
    if (has(spec, "relative_to"))
      unit += " (" + bound_text(lo, 1.0, "-inf") + " to " + bound_text(hi, 1.0, "inf") + " x " +
              last_part(text_of(spec, "relative_to")) + ")";
    // an unbounded side reads as open: (0, inf)
    throw InputError(where + ": must be in " + (lo_open || !lo ? "(" : "[") +
                     bound_text(lo, scale, "-inf") + ", " + bound_text(hi, scale, "inf") +
                     (hi_open || !hi ? ")" : "]") + unit + ", got " + format_g(x));
  }
  return x;
}

// An array of minItems to maxItems numbers (as many as its same_length_as field), each inside the
// field's range (named path[i], from 0) and, if `increasing`, strictly above the one before.
inline std::vector<double> check_array(const std::string &where, const json::Value &value,
                                       const json::Value &spec, const Values &values)
{
  if (value.kind != json::Value::ARRAY)
    throw InputError(where + ": must be an array of numbers, got " + json::kind_name(value.kind));
  const size_t n = value.array.size();
  const double low = spec.find("minItems")->number, high = spec.find("maxItems")->number;
  if (static_cast<double>(n) < low || static_cast<double>(n) > high)
    throw InputError(where + ": must have " + format_g(low) + " to " + format_g(high) +
                     " entries, got " + std::to_string(n));
  if (has(spec, "same_length_as")) {
    const std::string other = text_of(spec, "same_length_as");
    const size_t m = values.arrays.at(other).size();
    if (n != m)
      throw InputError(where + ": must have as many entries as " + other + " (" +
                       std::to_string(m) + "), got " + std::to_string(n));
  }
  const bool increasing = has(spec, "increasing") && spec.find("increasing")->boolean;
  std::vector<double> out;
  for (size_t i = 0; i < n; ++i) {
    const std::string entry = where + "[" + std::to_string(i) + "]";
    const double x = check_number(entry, value.array[i], spec, 1.0);
    if (increasing && !out.empty() && x <= out.back())
      throw InputError(entry + ": must be above " + where + "[" + std::to_string(i - 1) +
                       "] = " + format_g(out.back()) + " (strictly increasing), got " +
                       format_g(x));
    out.push_back(x);
  }
  return out;
}

inline void check_object(const std::string &path, const json::Value &data, Values &values);

// One field: `parent` is the object holding it (null when that object is absent).
inline void check_field(const json::Value &spec, const json::Value *parent, Values &values)
{
  const std::string path = text_of(spec, "path"), kind = text_of(spec, "type");
  const json::Value *value = parent ? parent->find(last_part(path)) : nullptr;
  const json::Value *without = spec.find("without");
  const bool excluded = without && parent && parent->find(without->string);
  if (value && excluded) {
    const std::string parent_path = path.substr(0, path.rfind('.'));
    throw InputError(path + ": must be left out beside " + parent_path + "." + without->string);
  }
  if (!value) {
    const json::Value *with = spec.find("with");
    // beside its "without" sibling a field is neither required nor needed by a "with"
    const bool needed =
        !excluded && (has(spec, "required") || (with && parent && parent->find(with->string)));
    if (parent && needed) throw InputError(path + ": missing");
    if (kind == "object") {
      for (const json::Value *child : children(path)) check_field(*child, nullptr, values);
    } else if (has(spec, "default")) {
      const json::Value &d = *spec.find("default");
      if (kind == "number") values.numbers[path] = default_number(spec);
      if (kind == "bool") values.bools[path] = d.boolean;
      if (kind == "string") values.strings[path] = d.string;
      if (kind == "array") values.arrays[path] = {};
    }
    return;
  }
  if (kind == "number") {
    const double scale =
        has(spec, "relative_to") ? values.numbers.at(text_of(spec, "relative_to")) : 1.0;
    values.numbers[path] = check_number(path, *value, spec, scale);
  } else if (kind == "array") {
    values.arrays[path] = check_array(path, *value, spec, values);
  } else if (kind == "bool") {
    if (value->kind != json::Value::BOOL)
      throw InputError(path + ": must be true or false, got " + json::kind_name(value->kind));
    values.bools[path] = value->boolean;
  } else if (kind == "string") {
    if (value->kind != json::Value::STRING)
      throw InputError(path + ": must be a string, got " + json::kind_name(value->kind));
    if (has(spec, "const") && value->string != text_of(spec, "const"))
      throw InputError(path + ": expected '" + text_of(spec, "const") + "', got " +
                       short_string(value->string));
    if (const json::Value *allowed = spec.find("enum")) {
      std::string list;
      bool found = false;
      for (const json::Value &a : allowed->array) {
        list += (list.empty() ? "" : ", ") + a.string;
        found = found || a.string == value->string;
      }
      if (!found)
        throw InputError(path + ": must be one of " + list + ", got " +
                         short_string(value->string));
    }
    values.strings[path] = value->string;
  } else if (kind == "object") {
    if (!value->is_object())
      throw InputError(path + ": must be a JSON object, got " + json::kind_name(value->kind));
    check_object(path, *value, values);
  }
}

inline void check_object(const std::string &path, const json::Value &data, Values &values)
{
  const std::vector<const json::Value *> known = children(path);
  const json::Value *spec = schema_field(path);
  if (!spec || text_of(*spec, "keys") == "closed") {
    for (const auto &kv : data.object) {
      bool ok = false;
      for (const json::Value *f : known) ok = ok || last_part(text_of(*f, "path")) == kv.first;
      if (!ok) {
        std::string list;
        for (const json::Value *f : known)
          list += (list.empty() ? "" : ", ") + last_part(text_of(*f, "path"));
        throw InputError((path.empty() ? "" : path + ".") + kv.first +
                         ": unknown key (allowed: " + list + ")");
      }
    }
  }
  for (const json::Value *f : known) check_field(*f, &data, values);
}

// Every field of the document checked against the schema, in its order (geocontact.schema).
inline Values validate(const json::Value &doc)
{
  if (!doc.is_object()) throw InputError("params: must hold a JSON object");
  Values values;
  check_object("", doc, values);
  return values;
}

// Where each named number of the schema goes in LawParams (the names of the Python classes).
inline double *number_slot(LawParams &p, const std::string &name)
{
  static const std::map<std::string, double LawParams::*> top = {
      {"yield_approach", &LawParams::yield_approach},
      {"elastic_plastic_exponent", &LawParams::elastic_plastic_exponent},
      {"fully_plastic_approach_ratio", &LawParams::fully_plastic_approach_ratio},
      {"fully_plastic_exponent", &LawParams::fully_plastic_exponent},
      {"deep_plastic_approach_ratio", &LawParams::deep_plastic_approach_ratio},
      {"deep_plastic_exponent", &LawParams::deep_plastic_exponent},
      {"unloading_power", &LawParams::unloading_power},
      {"reloading_power", &LawParams::reloading_power},
      {"residual_limit", &LawParams::residual_limit},
      {"residual_power", &LawParams::residual_power},
      {"residual_transition", &LawParams::residual_transition},
      {"residual_log_power", &LawParams::residual_log_power},
      {"plastic_work_limit", &LawParams::plastic_work_limit},
      {"plastic_work_power", &LawParams::plastic_work_power},
      {"plastic_work_transition", &LawParams::plastic_work_transition},
      {"plastic_work_log_power", &LawParams::plastic_work_log_power},
      {"calibrated_depth", &LawParams::calibrated_depth}};
  static const std::map<std::string, double Material::*> material = {
      {"youngs_modulus", &Material::youngs_modulus},
      {"poissons_ratio", &Material::poissons_ratio},
      {"compressive_yield_stress", &Material::compressive_yield_stress},
      {"friction_angle_deg", &Material::friction_angle_deg},
      {"hardening_ratio", &Material::hardening_ratio},
      {"radius", &Material::radius}};
  static const std::map<std::string, double CyclicLaw::*> cyclic = {
      {"residual_ratio_coefficient", &CyclicLaw::residual_ratio_coefficient},
      {"residual_ratio_power", &CyclicLaw::residual_ratio_power},
      {"plastic_work_ratio_coefficient", &CyclicLaw::plastic_work_ratio_coefficient},
      {"plastic_work_ratio_power", &CyclicLaw::plastic_work_ratio_power},
      {"tolerance", &CyclicLaw::tolerance}};
  const size_t dot = name.find('.');
  const std::string group = dot == std::string::npos ? "" : name.substr(0, dot);
  const std::string member = dot == std::string::npos ? name : name.substr(dot + 1);
  if (group.empty() && top.count(member)) return &(p.*top.at(member));
  if (group == "material" && material.count(member)) return &(p.material.*material.at(member));
  if (group == "cyclic" && cyclic.count(member)) return &(p.cyclic.*cyclic.at(member));
  return nullptr;
}

// The validated values into LawParams, by each field's name.
inline void fill(LawParams &p, const Values &values)
{
  for (const json::Value *f : schema_fields()) {
    const std::string path = text_of(*f, "path"), name = text_of(*f, "name"),
                      kind = text_of(*f, "type");
    if (name.empty() || kind == "object") continue;  // provenance, fit_errors: not used here
    if (kind == "number") {
      double *slot = number_slot(p, name);
      if (!slot)
        throw std::logic_error("law-schema.json: " + path + " (" + name +
                               ") has no member in params.hpp number_slot");
      if (values.numbers.count(path)) *slot = values.numbers.at(path);
    } else if (kind == "array" && (name == "loading_segments.depth" ||
                                   name == "loading_segments.exponent")) {
      if (f->find("maxItems")->number > LawParams::kMaxSegments)
        throw std::logic_error("law-schema.json: " + path + " allows more entries than "
                               "LawParams::kMaxSegments");
      const std::vector<double> &entries = values.arrays.at(path);
      double *slot = name == "loading_segments.depth" ? p.segment_depth : p.segment_exponent;
      std::copy(entries.begin(), entries.end(), slot);
      p.loading_segments = static_cast<int>(entries.size());
    } else if (kind == "array") {
      const std::map<std::string, std::vector<double> *> arrays = {
          {"residual_table.depth", &p.residual_table.depth},
          {"residual_table.ratio", &p.residual_table.ratio},
          {"radius_table.depth", &p.radius_table.depth},
          {"radius_table.envelope_ratio", &p.radius_table.envelope_ratio},
          {"radius_table.unloading_offset", &p.radius_table.unloading_offset},
          {"radius_table.unloading_power", &p.radius_table.unloading_power}};
      std::vector<double> *slot = arrays.count(name) ? arrays.at(name) : nullptr;
      if (!slot)
        throw std::logic_error("law-schema.json: " + path + " (" + name +
                               ") has no member in params.hpp fill");
      if (values.arrays.count(path)) *slot = values.arrays.at(path);
    } else if (name == "cyclic.enabled") {
      p.cyclic.enabled = values.bools.at(path);
    } else if (name == "label") {
      p.label = values.strings.at(path);
    } else if (name == "cyclic.form") {
      p.cyclic.shakedown = values.strings.at(path) == "shakedown";
    } else {
      throw std::logic_error("law-schema.json: " + path + " (" + name +
                             ") has no member in params.hpp fill");
    }
  }
}

// A cyclic ratio c N^-p applies from cycle 2 on, so its cycle-2 value must be in [0, 1].
inline void check_second_cycle(double coefficient, double power, const std::string &where)
{
  const double second = coefficient * std::pow(2.0, -power);
  if (second > 1.0)
    throw InputError(where + ": the cycle-2 ratio coefficient * 2^-power must be in [0, 1], got " +
                     format_g(second));
}

}  // namespace detail

// Reject parameter sets whose full-cycle plastic work is negative or shrinks with depth on
// x in [1, 1e7] (3001 geometric points, as params.py): such a law would create energy.
inline void check_energy(const LawParams &p)
{
  const int n = 3001;
  const double scale = p.yield_force * p.yield_approach;
  double previous = 0.0;
  for (int k = 0; k < n; ++k) {
    const double x = std::pow(10.0, 7.0 * k / (n - 1));
    const double wp = p.envelope_plastic_work(x * p.yield_approach) / scale;
    if (k == 0) previous = wp;
    if (wp < -1e-9 || wp - previous < -1e-9) {
      char buf[32];
      std::snprintf(buf, sizeof(buf), "%.4g", x);
      throw InputError(
          "unloading/residual_approach: this parameter set creates energy (the cycle's plastic "
          "work decreases) at delta_max/delta_y = " +
          std::string(buf) +
          "; raise " +
          std::string(p.residual_table.empty() ? "residual_approach.limit"
                                               : "the ratios of residual_approach.table") +
          " or lower loading.elastic_plastic_exponent");
    }
    previous = wp;
  }
}

// Parameters from a parsed `geocontact.law/1` document (validated; derived constants set).
// The rules between fields in the order of LawParams.from_dict (params.py).
inline LawParams params_from_json(const json::Value &doc)
{
  const detail::Values values = detail::validate(doc);
  LawParams p;
  detail::fill(p, values);
  if (p.deep_plastic_approach_ratio <= p.fully_plastic_approach_ratio)
    throw InputError("loading.deep_plastic_approach_ratio: must be above "
                     "loading.fully_plastic_approach_ratio (" +
                     detail::format_g(p.fully_plastic_approach_ratio) + "), got " +
                     detail::format_g(p.deep_plastic_approach_ratio));
  detail::check_second_cycle(p.cyclic.residual_ratio_coefficient, p.cyclic.residual_ratio_power,
                             "cyclic.residual_ratio");
  detail::check_second_cycle(p.cyclic.plastic_work_ratio_coefficient,
                             p.cyclic.plastic_work_ratio_power, "cyclic.plastic_work_ratio");
  if (p.loading_segments > 0 && p.segment_depth[0] != 1.0)
    throw InputError("loading.segments.depth[0]: the first segment starts at yield, must be 1, "
                     "got " + detail::format_g(p.segment_depth[0]));
  p.derive();
  check_energy(p);
  if (values.numbers.count("yield.force_N")) {
    const double given = values.numbers.at("yield.force_N");
    if (std::fabs(given - p.yield_force) > 1e-6 * p.yield_force) {
      char buf[200];
      std::snprintf(buf, sizeof(buf),
                    "yield.force_N: %.6g N disagrees with Hertz at yield.approach_m (%.6g N); "
                    "the two must describe the same point",
                    given, p.yield_force);
      throw InputError(buf);
    }
  }
  return p;
}

// JSON has no NaN or infinity, but Python's json reads the literals NaN, Infinity and
// -Infinity: both readers refuse them first, with the same message (geocontact.law.params,
// non_finite_literal), so the two never disagree on such a file.
inline void reject_non_finite_literals(const std::string &text, const std::string &source)
{
  static const char *const literals[] = {"-Infinity", "Infinity", "NaN"};
  bool in_string = false;
  int line = 1;
  size_t line_start = 0;
  for (size_t i = 0; i < text.size(); ++i) {
    const char c = text[i];
    if (c == '\n') {
      ++line;
      line_start = i + 1;
    } else if (in_string) {
      if (c == '\\') ++i;
      else if (c == '"') in_string = false;
    } else if (c == '"') {
      in_string = true;
    } else {
      for (const char *literal : literals)
        if (text.compare(i, std::char_traits<char>::length(literal), literal) == 0)
          throw InputError("params: malformed JSON in " + source + ": " + literal +
                           " at line " + std::to_string(line) + " column " +
                           std::to_string(i - line_start + 1) +
                           " (JSON has no NaN or infinity; give a finite number)");
    }
  }
}

inline LawParams parse_params(const std::string &text, const std::string &source = "parameters")
{
  reject_non_finite_literals(text, source);
  return params_from_json(json::parse(text, source));
}

inline std::string read_text_file(const std::string &path)
{
  // the messages of Python's files.read_text_input
  std::ifstream in(path, std::ios::binary);
  if (!in) throw InputError("params: file not found: " + path);
  if (std::filesystem::is_directory(path))
    throw InputError("params: " + path + " is a directory, expected a file");
  std::ostringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

// Read and validate a `geocontact.law/1` parameter file.
inline LawParams load_params(const std::string &path)
{
  return parse_params(read_text_file(path), path);
}

}  // namespace geocontact

#endif
