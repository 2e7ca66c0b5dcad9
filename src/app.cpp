#include "app.hpp"

#include <CLI/CLI.hpp>
#include <algorithm>
#include <cerrno>
#include <charconv>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <new>
#include <utility>
#include <stdexcept>

#if defined(__GLIBC__)
#include <malloc.h>
#endif

namespace sid::app {
namespace fs = std::filesystem;

namespace {

std::string trim(const std::string& s) {
  const char* ws = " \t\r\n";
  const auto begin = s.find_first_not_of(ws);
  if (begin == std::string::npos) return {};
  return s.substr(begin, s.find_last_not_of(ws) - begin + 1);
}

void print_error(const char* name, const char* kind, const std::string& message) {
  std::cerr << name << ": " << kind << ": " << message << std::endl;
}

}  // namespace

int report_errors(const char* name, const std::function<int()>& body) {
  // Order matters: CLI::Error and std::invalid_argument are also std::exception subclasses
  // that would be caught by the generic handlers below.
  try {
    return body();
  } catch (const CLI::ConstructionError& e) {
    print_error(name, "internal error", std::string("bad option definition: ") + e.what());
    return kExitInternalError;
  } catch (const std::invalid_argument& e) {
    print_error(name, "error", e.what());
    return kExitBadInput;
  } catch (const std::bad_alloc&) {
    print_error(name, "error", "out of memory (is the input file unexpectedly large?)");
    return kExitInternalError;
  } catch (const std::runtime_error& e) {  // InputError, I/O and filesystem errors
    print_error(name, "error", e.what());
    return kExitBadInput;
  } catch (const std::exception& e) {
    print_error(name, "internal error", e.what());
    return kExitInternalError;
  } catch (...) {
    print_error(name, "internal error", "unknown exception");
    return kExitInternalError;
  }
}

void tune_allocator() {
#if defined(__GLIBC__)
  // The apps allocate and free regressors of a few hundred kB per fit. glibc serves blocks that
  // large with fresh mmap()s, or trims the heap after each free, so every fit paid for zeroed
  // pages from the kernel: 40 % of the Monte Carlo study's time. Keeping such blocks in the
  // heap makes the study 1.6x faster; the cost is memory held until exit.
  constexpr int kLargeBlock = 64 << 20;
  mallopt(M_MMAP_THRESHOLD, kLargeBlock);
  mallopt(M_TRIM_THRESHOLD, 4 * kLargeBlock);
#endif
}

int run_app(const char* name, const std::string& description, int argc, char** argv,
            const std::function<void(CLI::App&)>& define_options, const std::function<int()>& run) {
  tune_allocator();
  return report_errors(name, [&]() -> int {
    CLI::App cli{description, name};
    define_options(cli);
    try {
      cli.parse(argc, argv);
    } catch (const CLI::ParseError& e) {
      // --help and --version arrive as "errors" with exit code 0; CLI11 prints them.
      if (e.get_exit_code() == static_cast<int>(CLI::ExitCodes::Success)) return cli.exit(e);
      print_error(name, "error", e.what());
      std::cerr << "Run '" << name << " --help' for the list of options." << std::endl;
      return kExitBadInput;
    }
    return run();
  });
}

void require(bool ok, const std::string& message) {
  if (!ok) throw InputError(message);
}

void ensure_writable(const std::string& path, bool force) {
  if (path == "-") return;
  require(!path.empty(), "empty output file name");
  const fs::path p(path);
  std::error_code ec;
  if (fs::is_directory(p, ec)) throw InputError("cannot write '" + path + "': it is a directory");
  const fs::path parent = p.parent_path();
  if (!parent.empty() && !fs::is_directory(parent, ec))
    throw InputError("cannot write '" + path + "': directory '" + parent.string() +
                     "' does not exist");
  if (fs::exists(p, ec) && !force)
    throw InputError("refusing to overwrite '" + path + "' (use --force)");
}

std::string ensure_output_directory(const std::string& dir, const std::vector<std::string>& files,
                                    bool force) {
  require(!dir.empty(), "empty output directory name");
  const fs::path d(dir);
  std::error_code ec;
  if (fs::exists(d, ec)) {
    if (!fs::is_directory(d, ec))
      throw InputError("cannot use '" + dir + "' as output directory: it is a file");
    if (!force)
      for (const auto& f : files)
        if (fs::exists(d / f, ec))
          throw InputError("refusing to overwrite '" + (d / f).string() + "' (use --force)");
  } else if (!fs::create_directories(d, ec) && ec) {
    throw InputError("cannot create directory '" + dir + "': " + ec.message());
  }
  return dir;
}

std::string ensure_output_directory(const std::string& dir, bool force) {
  require(!dir.empty(), "empty output directory name");
  std::error_code ec;
  if (!force && fs::is_directory(dir, ec) && !fs::is_empty(dir, ec))
    throw InputError("refusing to write into '" + dir +
                     "': it already holds files that could be overwritten (use --force)");
  return ensure_output_directory(dir, std::vector<std::string>{}, force);
}

std::string path_in(const std::string& dir, const std::string& file) {
  return (fs::path(dir) / file).string();
}

std::string torque_pairing(double delay) {
  return "each torque paired with the angles " + format_number("%.3g", 1e3 * std::abs(delay)) +
         (delay < 0.0 ? " ms later" : " ms earlier");
}

std::string shortest_number(double v) {
  char buffer[64];
  const auto result = std::to_chars(buffer, buffer + sizeof buffer, v);
  return std::string(buffer, result.ptr);
}

std::vector<double> parse_doubles(const std::string& text, const std::string& what) {
  const std::string all = trim(text);
  require(!all.empty(), what + ": no values given (expected numbers separated by commas)");
  std::vector<double> values;
  std::string::size_type start = 0;
  while (true) {
    const auto comma = all.find(',', start);
    const std::string cell = trim(all.substr(start, comma - start));
    const std::string which = what + ": value " + std::to_string(values.size() + 1);
    require(!cell.empty(), which + " is empty in '" + text + "'");
    char* end = nullptr;
    const double v = std::strtod(cell.c_str(), &end);
    require(end != cell.c_str() && *end == '\0', which + " '" + cell + "' is not a number");
    require(std::isfinite(v), which + " '" + cell + "' is not finite");
    values.push_back(v);
    if (comma == std::string::npos) break;
    start = comma + 1;
  }
  return values;
}

std::vector<std::string> parse_name_list(const std::string& text, const std::string& option,
                                         const std::string& item, const std::string& items,
                                         const std::string& expected) {
  require(!trim(text).empty(), option + ": no " + items + " given" +
                                   (expected.empty() ? "" : " (expected " + expected + ")"));
  std::vector<std::string> names;
  std::string::size_type start = 0;
  while (true) {
    const auto comma = text.find(',', start);
    const std::string name = trim(text.substr(start, comma - start));
    require(!name.empty(), option + ": empty " + item + " in '" + text + "'");
    for (const auto& seen : names)
      require(seen != name, option + ": '" + name + "' is given twice");
    names.push_back(name);
    if (comma == std::string::npos) break;
    start = comma + 1;
  }
  return names;
}

std::vector<sid::Effect> parse_effect_list(const std::string& text, const std::string& option) {
  std::vector<sid::Effect> effects;
  for (const std::string& id :
       parse_name_list(text, option, "effect id", "effects", sid::effect_id_list())) {
    try {
      effects.push_back(sid::Effect::parse(id, option.c_str()));
    } catch (const std::invalid_argument& e) {
      throw InputError(e.what());
    }
  }
  return effects;
}

std::vector<double> parse_doubles(const std::string& text, const std::string& what,
                                  std::size_t count) {
  std::vector<double> values = parse_doubles(text, what);
  require(values.size() == count, what + " needs " + std::to_string(count) + " value" +
                                      (count == 1 ? "" : "s") + ", got " +
                                      std::to_string(values.size()));
  return values;
}

nlohmann::json to_json_array(const Eigen::Ref<const Eigen::VectorXd>& v) {
  nlohmann::json out = nlohmann::json::array();
  for (Eigen::Index i = 0; i < v.size(); ++i) out.push_back(v[i]);
  return out;
}

nlohmann::json to_json_rows(const Eigen::Ref<const Eigen::MatrixXd>& m) {
  nlohmann::json out = nlohmann::json::array();
  for (Eigen::Index i = 0; i < m.rows(); ++i) {
    nlohmann::json row = nlohmann::json::array();
    for (Eigen::Index j = 0; j < m.cols(); ++j) row.push_back(m(i, j));
    out.push_back(std::move(row));
  }
  return out;
}

void write_json(const std::string& path, const nlohmann::json& value) {
  // nlohmann::json prints doubles as the shortest text that reads back bit-identical.
  const std::string text =
      value.dump(2, ' ', false, nlohmann::json::error_handler_t::replace) + "\n";
  if (path == "-") {
    std::cout << text << std::flush;
    if (!std::cout) throw std::runtime_error("cannot write to standard output");
    return;
  }
  write_text(path, text);
}

void write_text(const std::string& path, const std::string& text) {
  std::ofstream out(path, std::ios::binary);
  if (!out)
    throw std::runtime_error("cannot open '" + path + "' for writing: " + std::strerror(errno));
  out << text;
  out.close();
  if (!out) throw std::runtime_error("error while writing '" + path + "' (disk full?)");
}

std::vector<std::pair<std::string, std::string>> parse_assignments(const std::string& text,
                                                                   const std::string& option,
                                                                   const std::string& form) {
  std::vector<std::pair<std::string, std::string>> pairs;
  for (const std::string& item : parse_name_list(text, option, "entry", "entries", form)) {
    const auto eq = item.find('=');
    if (eq == std::string::npos) throw InputError(option + ": '" + item + "' is not " + form);
    const std::string key = trim(item.substr(0, eq)), value = trim(item.substr(eq + 1));
    for (const auto& seen : pairs)
      if (seen.first == key) throw InputError(option + ": key '" + key + "' is given twice");
    pairs.emplace_back(key, value);
  }
  return pairs;
}

TrajectoryColumns parse_trajectory_columns(const std::string& text, const std::string& option) {
  TrajectoryColumns columns;
  const std::vector<std::pair<const char*, std::string*>> keys{{"t", &columns.t},
                                                               {"q1", &columns.q1},
                                                               {"q2", &columns.q2},
                                                               {"tau1", &columns.tau1},
                                                               {"tau2", &columns.tau2}};
  for (const auto& [key, name] :
       parse_assignments(text, option, "KEY=NAME (keys: t, q1, q2, tau1, tau2)")) {
    const auto hit =
        std::find_if(keys.begin(), keys.end(), [&](const auto& k) { return key == k.first; });
    if (hit == keys.end())
      throw InputError(option + ": unknown key '" + key + "' in '" + key + "=" + name +
                       "' (keys: t, q1, q2, tau1, tau2)");
    if (name.empty()) throw InputError(option + ": no column name after '" + key + "='");
    *hit->second = name;
  }
  return columns;
}

std::string format_number(const char* format, double v) {
  if (std::isnan(v)) return "n/a";
  char buffer[64];
  std::snprintf(buffer, sizeof buffer, format, v);
  return buffer;
}

}  // namespace sid::app

namespace sid::app {

std::uint64_t parse_seed(const std::string& text) {
  std::uint64_t seed = 0;
  const char* end = text.data() + text.size();
  const auto result = std::from_chars(text.data(), end, seed);
  require(!text.empty() && result.ec == std::errc() && result.ptr == end,
          "--seed must be an integer from 0 to 18446744073709551615, got '" + text + "'");
  return seed;
}

}  // namespace sid::app
