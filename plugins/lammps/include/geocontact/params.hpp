// geocontact: read and validate a `geocontact.law/1` parameter file into LawParams.
// The same checks and one-line messages as src/geocontact/law/params.py (field, allowed range).
#ifndef GEOCONTACT_PARAMS_HPP
#define GEOCONTACT_PARAMS_HPP

#include "geocontact/json.hpp"
#include "geocontact/law.hpp"

#include <cmath>
#include <cstdio>
#include <fstream>
#include <initializer_list>
#include <sstream>
#include <string>

namespace geocontact {

constexpr const char *kSchema = "geocontact.law/1";

namespace detail {

inline std::string format_g(double value)
{
  char buf[64];
  std::snprintf(buf, sizeof(buf), "%g", value);
  return buf;
}

inline const json::Value &object_at(const json::Value &parent, const std::string &key,
                                    const std::string &where)
{
  const json::Value *v = parent.find(key);
  if (!v) throw InputError(where + ": missing");
  if (!v->is_object()) throw InputError(where + ": must be an object");
  return *v;
}

inline void check_keys(const json::Value &obj, const std::string &where,
                       std::initializer_list<const char *> allowed)
{
  if (!obj.is_object()) throw InputError(where + ": must be an object");
  for (const auto &kv : obj.object) {
    bool ok = false;
    for (const char *a : allowed) ok = ok || kv.first == a;
    if (!ok) {
      std::string list;
      for (const char *a : allowed) list += (list.empty() ? "" : ", ") + std::string(a);
      throw InputError(where + "." + kv.first + ": unknown key (allowed: " + list + ")");
    }
  }
}

// A finite number in a range; lo/hi are NaN when unbounded.
inline double number(const json::Value &obj, const std::string &where, const std::string &key,
                     double lo = NAN, double hi = NAN, bool lo_open = false,
                     bool hi_open = false)
{
  const json::Value *v = obj.find(key);
  const std::string field = where + "." + key;
  if (!v) throw InputError(field + ": missing");
  if (v->kind != json::Value::NUMBER)
    throw InputError(field + ": expected a number, got " + json::kind_name(v->kind));
  const double x = v->number;
  if (!std::isfinite(x)) throw InputError(field + ": must be finite");
  const bool bad_lo = !std::isnan(lo) && (lo_open ? x <= lo : x < lo);
  const bool bad_hi = !std::isnan(hi) && (hi_open ? x >= hi : x > hi);
  if (bad_lo || bad_hi) {
    const std::string range = std::string(lo_open ? "(" : "[") +
        (std::isnan(lo) ? "-inf" : format_g(lo)) + ", " +
        (std::isnan(hi) ? "inf" : format_g(hi)) + (hi_open ? ")" : "]");
    throw InputError(field + ": must be in " + range + ", got " + format_g(x));
  }
  return x;
}

// A cyclic ratio c N^-p applies from cycle 2 on, so its cycle-2 value must be in [0, 1].
inline void check_second_cycle(double coefficient, double power, const std::string &where)
{
  const double second = coefficient * std::pow(2.0, -power);
  if (second > 1.0)
    throw InputError(where + ": the cycle-2 ratio coefficient * 2^-power must be in [0, 1], got " +
                     format_g(second));
}

inline Material parse_material(const json::Value &m)
{
  check_keys(m, "material",
             {"youngs_modulus", "poissons_ratio", "compressive_yield_stress",
              "friction_angle_deg", "hardening_ratio", "radius"});
  Material mat;
  // Same ranges as geocontact.material.Material (SPEC sections 2-3).
  mat.youngs_modulus = number(m, "material", "youngs_modulus", 0.0, NAN, true);
  mat.poissons_ratio = number(m, "material", "poissons_ratio", -1.0, 0.5, true, true);
  mat.compressive_yield_stress =
      number(m, "material", "compressive_yield_stress", 0.0, NAN, true);
  // tan(beta) < 3 keeps the cohesion factor (1 - tan(beta)/3) positive.
  const double max_friction_angle = std::atan(3.0) * 45.0 / std::atan(1.0);
  mat.friction_angle_deg =
      number(m, "material", "friction_angle_deg", 0.0, max_friction_angle, false, true);
  mat.hardening_ratio = number(m, "material", "hardening_ratio", 0.0, 1.0, false, true);
  mat.radius = number(m, "material", "radius", 0.0, NAN, true);
  return mat;
}

inline CyclicLaw parse_cyclic(const json::Value *c)
{
  CyclicLaw cyc;
  if (!c) return cyc;
  check_keys(*c, "cyclic",
             {"enabled", "residual_ratio", "plastic_work_ratio", "tolerance", "critical_cycle",
              "form"});
  if (const json::Value *f = c->find("form")) {
    // same message as geocontact.law.params.CyclicLaw.from_dict
    if (f->kind != json::Value::STRING || (f->string != "truncated" && f->string != "shakedown"))
      throw InputError("cyclic.form: must be one of truncated, shakedown, got " +
                       (f->kind == json::Value::STRING ? "\"" + f->string + "\"" : "a non-string value"));
    cyc.shakedown = f->string == "shakedown";
  }
  if (const json::Value *e = c->find("enabled")) {
    if (e->kind != json::Value::BOOL) throw InputError("cyclic.enabled: must be true or false");
    cyc.enabled = e->boolean;
  }
  json::Value empty;
  empty.kind = json::Value::OBJECT;
  const json::Value *rr = c->find("residual_ratio");
  const json::Value *pw = c->find("plastic_work_ratio");
  if (!rr) rr = &empty;
  if (!pw) pw = &empty;
  check_keys(*rr, "cyclic.residual_ratio", {"coefficient", "power"});
  check_keys(*pw, "cyclic.plastic_work_ratio", {"coefficient", "power"});
  cyc.residual_ratio_coefficient = number(*rr, "cyclic.residual_ratio", "coefficient", 0.0, NAN);
  cyc.residual_ratio_power = number(*rr, "cyclic.residual_ratio", "power", 0.0, NAN, true);
  cyc.plastic_work_ratio_coefficient =
      number(*pw, "cyclic.plastic_work_ratio", "coefficient", 0.0, NAN);
  cyc.plastic_work_ratio_power =
      number(*pw, "cyclic.plastic_work_ratio", "power", 0.0, NAN, true);
  // The ratio applies from cycle 2 on: c N^-p may exceed 1 only before cycle 2.
  check_second_cycle(cyc.residual_ratio_coefficient, cyc.residual_ratio_power,
                     "cyclic.residual_ratio");
  check_second_cycle(cyc.plastic_work_ratio_coefficient, cyc.plastic_work_ratio_power,
                     "cyclic.plastic_work_ratio");
  cyc.tolerance = number(*c, "cyclic", "tolerance", 0.0, 1.0, true);
  return cyc;
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
          "; raise residual_approach.limit or lower loading.elastic_plastic_exponent");
    }
    previous = wp;
  }
}

// Parameters from a parsed `geocontact.law/1` document (validated; derived constants set).
inline LawParams params_from_json(const json::Value &doc)
{
  using detail::number;
  if (!doc.is_object()) throw InputError("params: must hold a JSON object");
  detail::check_keys(doc, "params",
                     {"schema", "label", "material", "yield", "loading", "unloading",
                      "reloading", "residual_approach", "plastic_work", "cyclic", "provenance",
                      "fit_errors"});
  const json::Value *schema = doc.find("schema");
  if (!schema || schema->kind != json::Value::STRING || schema->string != kSchema)
    throw InputError(std::string("schema: expected '") + kSchema + "', got " +
                     (!schema ? "nothing"
                              : schema->kind == json::Value::STRING
                             ? "'" + schema->string + "'"
                             : json::kind_name(schema->kind)));
  for (const char *key :
       {"material", "yield", "loading", "unloading", "reloading", "residual_approach"})
    if (!doc.find(key)) throw InputError(std::string(key) + ": missing");

  LawParams p;
  p.material = detail::parse_material(detail::object_at(doc, "material", "material"));
  const json::Value &yd = detail::object_at(doc, "yield", "yield");
  p.yield_approach = number(yd, "yield", "approach_m", 0.0, NAN, true);
  const json::Value &ld = detail::object_at(doc, "loading", "loading");
  detail::check_keys(ld, "loading",
                     {"elastic_plastic_exponent", "fully_plastic_approach_ratio",
                      "fully_plastic_exponent", "fully_plastic_approach_m",
                      "fully_plastic_force_N", "deep_plastic_approach_ratio",
                      "deep_plastic_exponent", "deep_plastic_approach_m",
                      "deep_plastic_force_N"});
  p.elastic_plastic_exponent = number(ld, "loading", "elastic_plastic_exponent", 0.0, 3.0, true);
  p.fully_plastic_approach_ratio = number(ld, "loading", "fully_plastic_approach_ratio", 1.0);
  p.fully_plastic_exponent = number(ld, "loading", "fully_plastic_exponent", 0.0, 3.0, true);
  if (ld.find("deep_plastic_approach_ratio") || ld.find("deep_plastic_exponent")) {
    p.deep_plastic_approach_ratio = number(ld, "loading", "deep_plastic_approach_ratio",
                                           p.fully_plastic_approach_ratio, NAN, true);
    p.deep_plastic_exponent = number(ld, "loading", "deep_plastic_exponent", 0.0, 3.0, true);
  }
  const json::Value &ud = detail::object_at(doc, "unloading", "unloading");
  detail::check_keys(ud, "unloading", {"exponent_power"});
  p.unloading_power = number(ud, "unloading", "exponent_power", -1.0, 1.0);
  const json::Value &rd = detail::object_at(doc, "reloading", "reloading");
  detail::check_keys(rd, "reloading", {"exponent_power"});
  p.reloading_power = number(rd, "reloading", "exponent_power", -1.0, 1.0);
  const json::Value &sd = detail::object_at(doc, "residual_approach", "residual_approach");
  detail::check_keys(sd, "residual_approach",
                     {"limit", "power", "transition_depth", "log_power"});
  p.residual_limit = number(sd, "residual_approach", "limit", 0.0, 1.0, false, true);
  p.residual_power = number(sd, "residual_approach", "power", 0.0, 10.0, true);
  if (sd.find("transition_depth"))
    p.residual_transition = number(sd, "residual_approach", "transition_depth", 0.0, 1e6, true);
  if (sd.find("log_power"))
    p.residual_log_power = number(sd, "residual_approach", "log_power", 0.2, 5.0);
  if (const json::Value *pw = doc.find("plastic_work")) {
    detail::check_keys(*pw, "plastic_work", {"limit", "power", "transition_depth", "log_power"});
    p.plastic_work_limit = number(*pw, "plastic_work", "limit", 0.0, 1.0);
    p.plastic_work_power = number(*pw, "plastic_work", "power", 0.0, 10.0, true);
    if (pw->find("transition_depth"))
      p.plastic_work_transition =
          number(*pw, "plastic_work", "transition_depth", 0.0, 1e6, true);
    if (pw->find("log_power"))
      p.plastic_work_log_power = number(*pw, "plastic_work", "log_power", 0.2, 5.0);
  }
  p.cyclic = detail::parse_cyclic(doc.find("cyclic"));
  if (const json::Value *label = doc.find("label"))
    if (label->kind == json::Value::STRING) p.label = label->string;
  p.derive();
  check_energy(p);
  if (yd.find("force_N")) {
    const double given = number(yd, "yield", "force_N", 0.0, NAN, true);
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

inline LawParams parse_params(const std::string &text, const std::string &source = "parameters")
{
  return params_from_json(json::parse(text, source));
}

inline std::string read_text_file(const std::string &path)
{
  std::ifstream in(path, std::ios::binary);
  if (!in) throw InputError("params: file not found or unreadable: " + path);
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
