// SPDX-License-Identifier: GPL-3.0-or-later
// --config, the resolved configuration and the provenance record (app/run_config.hpp).
#include "app/run_config.hpp"

#include <omp.h>
#include <unistd.h>

#include <cerrno>
#include <chrono>
#include <cstdlib>
#include <cstring>
#include <ctime>
#include <fstream>
#include <map>
#include <sstream>

#include "app/cli_util.hpp"
#include "core/blas_threads.hpp"
#include "core/io.hpp"
#include "core/validation.hpp"
#include "core/version.hpp"

namespace rbc::app {

namespace {

/// Every option of `cmd` and of its option groups (nameless sub-commands), in the order added.
std::vector<CLI::Option*> command_options(CLI::App& cmd) {
  std::vector<CLI::Option*> all = cmd.get_options();
  for (CLI::App* group : cmd.get_subcommands([](CLI::App* s) { return s->get_name().empty(); }))
    for (CLI::Option* o : command_options(*group)) all.push_back(o);
  return all;
}

bool is_flag(const CLI::Option* o) {
  return o->get_expected_max() == 0;
}

/// Whether two option texts say the same: equal text, equal numbers, or equal lists of numbers.
bool same_value(const std::string& a, const std::string& b) {
  if (a == b) return true;
  std::stringstream sa(a), sb(b);
  std::string ia, ib;
  while (true) {
    const bool more_a = static_cast<bool>(std::getline(sa, ia, ','));
    const bool more_b = static_cast<bool>(std::getline(sb, ib, ','));
    if (more_a != more_b) return false;
    if (!more_a) return true;
    const auto xa = parse_finite_number(ia), xb = parse_finite_number(ib);
    if (!xa || !xb || *xa != *xb) return false;
  }
}

/// The value -> name map an enum_choice validator keeps in its name, if `o` has one.
std::map<std::string, std::string> enum_names(CLI::Option* o) {
  std::map<std::string, std::string> names;
  for (int i = 0;; ++i) {
    CLI::Validator* v = nullptr;
    try {
      v = o->get_validator(i);
    } catch (const CLI::OptionNotFound&) {
      break;
    }
    const std::string& name = v->get_name();
    if (name.rfind(kEnumChoicePrefix, 0) != 0) continue;
    std::stringstream items(name.substr(kEnumChoicePrefix.size()));
    for (std::string item; std::getline(items, item, ';');)
      if (const auto eq = item.find('='); eq != std::string::npos)
        names[item.substr(0, eq)] = item.substr(eq + 1);
  }
  return names;
}

/// One option value as JSON: an integer, a real number, a list of numbers, or the text.
nlohmann::json value_json(const std::string& text) {
  if (const auto i = parse_integer(text)) return *i;
  if (const auto x = parse_finite_number(text)) return *x;
  if (text.find(',') != std::string::npos) {
    nlohmann::json list = nlohmann::json::array();
    std::stringstream items(text);
    for (std::string item; std::getline(items, item, ',');) {
      if (const auto i = parse_integer(item))
        list.push_back(*i);
      else if (const auto x = parse_finite_number(item))
        list.push_back(*x);
      else
        return text;
    }
    return list;
  }
  return text;
}

/// A JSON value of a configuration file as the option text CLI11 parses ("" when it cannot be
/// one: an object, or an array holding one).
std::string option_text(const nlohmann::json& v) {
  if (v.is_string()) return v.get<std::string>();
  if (v.is_number() || v.is_boolean()) return v.dump();
  if (v.is_array()) {
    std::string joined;
    for (const auto& item : v) {
      if (!(item.is_number() || item.is_string())) return "";
      joined += (joined.empty() ? "" : ",") + option_text(item);
    }
    return joined;
  }
  return "";
}

[[noreturn]] void config_error(const std::string& path, const std::string& what) {
  throw CLI::ConfigError("--config " + path + ": " + what);
}

/// Gives every option of `cmd` that the command line left unset its value from the file.
void apply_config(CLI::App& cmd, const std::string& path) {
  std::ifstream in(path);
  if (!in) config_error(path, std::string("cannot open: ") + std::strerror(errno));
  nlohmann::json file;
  try {
    file = nlohmann::json::parse(in);
  } catch (const nlohmann::json::exception& e) {
    config_error(path, std::string("not valid JSON (") + e.what() + ")");
  }
  if (!file.is_object()) config_error(path, "expected a JSON object of option names and values");
  // A run's record: the options are its "config"; the rest describes the outcome.
  const nlohmann::json* options = &file;
  if (file.contains("config")) {
    if (file.contains("command") && file["command"] != cmd.get_name())
      config_error(path,
                   "written by rbc " + file["command"].dump() + ", not rbc " + cmd.get_name());
    options = &file["config"];
    if (!options->is_object()) config_error(path, "\"config\" is not a JSON object");
  }
  for (const auto& [key, value] : options->items()) {
    CLI::Option* o = cmd.get_option_no_throw("--" + key);
    if (o == nullptr || key == "help" || key == "config")
      config_error(path, "'" + key + "' is not an option of rbc " + cmd.get_name());
    if (o->count() > 0 || value.is_null()) continue;  // the command line wins
    if (is_flag(o)) {
      if (!value.is_boolean())
        config_error(path, "'" + key + "' is a flag: expected true or false, got " + value.dump());
      if (value.get<bool>()) o->add_result(o->get_flag_value(key, "true"));
      continue;
    }
    const std::string text = option_text(value);
    if (text.empty() && !value.is_string())
      config_error(path, "'" + key + "': expected a number, a text or a list, got " + value.dump());
    // A value equal to the default is left unset: a run.json lists every default, and an option
    // the run did not set must stay unset (some options only apply when given).
    if (same_value(text, o->get_default_str())) continue;
    o->add_result(text);
  }
}

/// The command line of this process, each argument shell-quoted where it needs it.
std::string command_line() {
  std::ifstream in("/proc/self/cmdline", std::ios::binary);
  std::string line, arg;
  while (std::getline(in, arg, '\0')) {
    const bool plain = !arg.empty() && arg.find_first_not_of(
                                           "abcdefghijklmnopqrstuvwxyzABCDEFGHIJKLMNOPQRSTUVWXYZ"
                                           "0123456789-_./=,:%+@") == std::string::npos;
    std::string quoted = arg;
    if (!plain) {
      quoted = "'";
      for (char c : arg) quoted += c == '\'' ? std::string("'\\''") : std::string(1, c);
      quoted += "'";
    }
    line += (line.empty() ? "" : " ") + quoted;
  }
  return line;
}

std::string utc_now() {
  const std::time_t t = std::chrono::system_clock::to_time_t(std::chrono::system_clock::now());
  std::tm tm{};
  gmtime_r(&t, &tm);
  char buf[32];
  std::strftime(buf, sizeof buf, "%Y-%m-%dT%H:%M:%SZ", &tm);
  return buf;
}

}  // namespace

void add_config_option(CLI::App* cmd) {
  cmd->add_option_function<std::string>(
         "--config", [cmd](const std::string& path) { apply_config(*cmd, path); },
         "read the options from a JSON file ({\"persistence\": 10, ...}, or a run.json this "
         "command wrote); options on the command line override it")
      ->type_name("FILE");
}

nlohmann::json resolved_config(const CLI::App& cmd_const) {
  auto& cmd = const_cast<CLI::App&>(cmd_const);  // CLI11's validator lookup is not const
  nlohmann::json config = nlohmann::json::object();
  for (CLI::Option* o : command_options(cmd)) {
    const std::string key = o->get_single_name();
    if (key.empty() || key == "help" || key == "config" || key == "version") continue;
    if (is_flag(o)) {
      config[key] = o->count() > 0;
      continue;
    }
    const auto names = enum_names(o);
    // Text options stay text (a path "1e5" is not a number) unless they hold a list of numbers.
    const bool text = o->get_type_name() == "TEXT";
    // Given values of a choice are stored as their number (enum_choice); defaults as their name.
    auto as_json = [&](const std::string& value, bool given) -> nlohmann::json {
      if (!names.empty()) {
        const auto it = names.find(value);
        return given && it != names.end() ? it->second : value;
      }
      nlohmann::json j = value_json(value);
      return text && !j.is_array() ? nlohmann::json(value) : j;
    };
    if (o->count() > 0) {
      const std::vector<std::string>& r = o->results();
      if (r.size() == 1) {
        config[key] = as_json(r.front(), true);
      } else {
        nlohmann::json list = nlohmann::json::array();
        for (const auto& text : r) list.push_back(as_json(text, true));
        config[key] = list;
      }
    } else if (!o->get_default_str().empty()) {
      config[key] = as_json(o->get_default_str(), false);
    } else {
      config[key] = nullptr;
    }
  }
  return config;
}

nlohmann::json provenance_json() {
  char host[256] = {};
  if (gethostname(host, sizeof host - 1) != 0) host[0] = '\0';
  const BlasInfo blas = blas_info();
  return {{"rbc_version", version_string()},
          {"command_line", command_line()},
          {"date_utc", utc_now()},
          {"host", std::string(host)},
          {"openmp_threads", omp_get_max_threads()},
          {"omp_wait_policy", std::getenv("OMP_WAIT_POLICY") ? std::getenv("OMP_WAIT_POLICY") : ""},
          {"blas", {{"library", blas.library}, {"core", blas.core}, {"config", blas.config}}}};
}

nlohmann::json run_record(const CLI::App& cmd) {
  return {{"command", cmd.get_name()},
          {"config", resolved_config(cmd)},
          {"provenance", provenance_json()}};
}

void write_run_record(const std::string& dir, const nlohmann::json& record) {
  nlohmann::json run = record;
  run["status"] = "finished";
  write_text_atomic(dir + "/run.json", run.dump(2) + "\n");
}

std::vector<std::string> record_comment_lines(const nlohmann::json& record) {
  const nlohmann::json& p = record.at("provenance");
  std::ostringstream machine;
  machine << "date_utc " << p.at("date_utc").get<std::string>() << ", host "
          << p.at("host").get<std::string>() << ", openmp_threads " << p.at("openmp_threads")
          << ", blas " << p.at("blas").at("library").get<std::string>() << " "
          << p.at("blas").at("core").get<std::string>();
  return {"rbc " + p.at("rbc_version").get<std::string>() + ": " +
              p.at("command_line").get<std::string>(),
          machine.str(), "config " + record.at("config").dump()};
}

std::vector<std::pair<std::string, std::string>> record_png_text(const nlohmann::json& record) {
  const nlohmann::json& p = record.at("provenance");
  return {{"Software", "rbc " + p.at("rbc_version").get<std::string>()},
          {"Source", p.at("command_line").get<std::string>()},
          {"Creation Time", p.at("date_utc").get<std::string>()},
          {"rbc_config", record.at("config").dump()}};
}

std::vector<std::pair<std::string, std::string>> record_attributes(const nlohmann::json& record) {
  const nlohmann::json& p = record.at("provenance");
  return {{"rbc_version", p.at("rbc_version").get<std::string>()},
          {"rbc_command_line", p.at("command_line").get<std::string>()},
          {"rbc_config", record.at("config").dump()},
          {"rbc_provenance", p.dump()}};
}

}  // namespace rbc::app
