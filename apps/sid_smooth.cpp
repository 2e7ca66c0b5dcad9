// sid_smooth: smooth CSV columns with the Reinsch smoothing spline and write the value, first and
// second derivative of each at the input times.

#include <CLI/CLI.hpp>
#include <cmath>
#include <cstdio>
#include <iostream>
#include <optional>
#include <sid/identify.hpp>
#include <sid/close_abscissae.hpp>
#include <sid/smoothing_spline.hpp>
#include <stdexcept>
#include <string>
#include <vector>

#include "app.hpp"
#include "csv.hpp"

namespace {

constexpr const char* kName = "sid_smooth";

constexpr const char* kDescription =
    "Smooth the columns of a CSV file with the Reinsch cubic smoothing spline and write, for each\n"
    "smoothed signal NAME, the columns NAME, NAME_d, NAME_dd: the smoothed value and its first "
    "and\n"
    "second derivative with respect to time, at the input times.\n";

constexpr const char* kFooter = R"(
Input: a CSV file with a header row of column names; lines starting with '#' are comments;
blank lines are skipped; columns may come in any order. The time column must be strictly
increasing; every cell must be a finite number.

Output (standard output unless --output): the time column, then NAME,NAME_d,NAME_dd for each
smoothed signal, 17 significant digits. Derivatives are per unit of the time column.

Noise level: --sigma gives the standard deviation dy of the measurement noise of each signal,
in the signal's own units (one value for all signals, or one per signal, comma-separated, in the
order of the output). --weights COL instead reads a per-sample standard deviation from column COL
(used for every signal). Neither is needed for gcv and cv, which estimate the noise level.

Smoothing amount (--smoothing):
  gcv           (default without --sigma, --weights, --S and --lambda) penalty form with lambda
                chosen from the data by minimising generalized cross-validation (Craven & Wahba
                1979): no noise level needed. --sigma/--weights, if given, only set relative
                weights (default: all samples alike). Needs at least 4 samples. The fit
                estimates the noise: sigma_hat = sqrt(F / (n - tr A)) in the signal's units (with
                --weights: as a multiple of dy), where tr A is the equivalent degrees of freedom
                of the fit (2 = straight line, n = interpolation).
  cv            the same with ordinary leave-one-out cross-validation.
  s-constraint  (default with --sigma, --weights or --S) constraint form (Reinsch 1967): the
                smoothest spline g whose weighted residual F = sum(((g(t_i) - y_i) / dy_i)^2) is
                at most S = --S. With the right dy each term of F is about 1, so the default
                S = n (number of samples) is the natural choice; S = 0 interpolates, a large S
                gives the least-squares straight line. With --S alone dy = 1 and S is a sum of
                squared residuals.
  lambda        (implied by --lambda V) penalty form: minimise
                sum(w_i (y_i - g(t_i))^2) + lambda * integral(g''^2) with w_i = 1/dy_i^2 (1
                without --sigma/--weights), the same as SciPy's make_smoothing_spline(t, y, w,
                lam=lambda). lambda = 1/p in Reinsch's notation; larger lambda gives a smoother
                curve. lambda depends on the units of t and y (it scales like time^3), so S is
                easier to choose.
--S goes only with s-constraint, --lambda only with lambda.

For every signal the chosen p, lambda = 1/p, the achieved F and the iteration count (for gcv
and cv: criterion evaluations), and for gcv and cv also tr A and sigma_hat, are printed to
standard error (unless --quiet).

Exit codes: 0 success, 2 bad input or options (message on standard error), 1 internal error.

Examples:
  sid_smooth --signal q1,q2 -o smoothed.csv log.csv
  sid_smooth --sigma 0.001 --signal q1,q2 -o smoothed.csv log.csv
)";

struct Options {
  std::string input;
  std::string time = "t";
  std::vector<std::string> signals;
  std::string sigma;
  std::string weights;
  std::optional<double> S;
  std::optional<double> lambda;
  std::string smoothing;
  std::string output = "-";
  bool force = false;
  bool quiet = false;
};

void define_options(CLI::App& cli, Options& o) {
  cli.footer(kFooter);
  cli.add_option("INPUT", o.input, "input CSV file ('-' reads standard input)")->required();
  cli.add_option("--time", o.time, "name of the time column")->capture_default_str();
  cli.add_option("--signal", o.signals,
                 "column to smooth; repeat or separate by commas (default: every column but the "
                 "time and --weights columns)")
      ->delimiter(',');
  auto* sigma = cli.add_option("--sigma", o.sigma,
                               "noise standard deviation dy > 0: one value, or one per signal "
                               "separated by commas (relative weights for gcv and cv)");
  auto* weights = cli.add_option("--weights", o.weights,
                                 "column holding a per-sample noise standard deviation dy > 0 "
                                 "(instead of --sigma; relative weights for gcv and cv)");
  sigma->excludes(weights);
  auto* s = cli.add_option("--S", o.S,
                           "constraint form: allowed weighted residual F <= S, S >= 0 "
                           "(default: S = n, the number of samples)");
  auto* lambda = cli.add_option("--lambda", o.lambda,
                                "penalty form: roughness weight lambda > 0 (SciPy's lam; "
                                "lambda = 1/p)");
  s->excludes(lambda);
  cli.add_option("--smoothing", o.smoothing,
                 "s-constraint, gcv, cv or lambda (default: lambda with --lambda, s-constraint "
                 "with --sigma, --weights or --S, otherwise gcv)");
  cli.add_option("-o,--output", o.output, "output CSV file ('-' is standard output)")
      ->capture_default_str();
  cli.add_flag("--force", o.force, "overwrite the output file if it exists");
  cli.add_flag("-q,--quiet", o.quiet, "do not print the per-signal fit summary");
}

std::string join(const std::vector<std::string>& names) {
  std::string out;
  for (std::size_t j = 0; j < names.size(); ++j) out += (j ? ", " : "") + names[j];
  return out;
}

std::vector<std::string> choose_signals(const sid::app::CsvTable& table, const Options& o) {
  using sid::app::require;
  std::vector<std::string> signals;
  if (o.signals.empty()) {
    for (const auto& name : table.names)
      if (name != o.time && name != o.weights) signals.push_back(name);
    require(!signals.empty(), table.source + ": nothing to smooth: the only column" +
                                  (table.names.size() > 1 ? "s are" : " is") + " " +
                                  join(table.names) + " (time" +
                                  (o.weights.empty() ? "" : " and weights") + ")");
    return signals;
  }
  for (const auto& name : o.signals) {
    require(!name.empty(), "--signal: empty column name");
    table.index_of(name);  // throws "no column 'x'; columns are: ..."
    require(name != o.time, "--signal " + name + ": that is the time column");
    require(name != o.weights, "--signal " + name + ": that is the --weights column");
    for (const auto& seen : signals) require(seen != name, "--signal " + name + " is given twice");
    signals.push_back(name);
  }
  return signals;
}

std::string short_number(double v) {
  char buffer[32];
  std::snprintf(buffer, sizeof buffer, "%.6g", v);
  return buffer;
}

using Mode = sid::SmoothingMode;

// The smoothing mode: --smoothing, or implied by the other options; rejects the combinations
// that make no sense.
Mode choose_mode(const Options& o) {
  using sid::app::require;
  const bool noise = !o.sigma.empty() || !o.weights.empty();
  Mode mode = Mode::Gcv;
  if (!o.smoothing.empty()) {
    try {
      mode = sid::parse_smoothing_mode(o.smoothing);
    } catch (const std::invalid_argument&) {
      throw sid::app::InputError("--smoothing: unknown mode '" + o.smoothing +
                                 "' (expected s-constraint, gcv, cv or lambda)");
    }
  } else if (o.lambda) {
    mode = Mode::Lambda;
  } else if (noise || o.S) {
    mode = Mode::SConstraint;
  }
  const std::string name = sid::smoothing_mode_name(mode);
  if (mode != Mode::SConstraint)
    require(!o.S, "--S does not apply to --smoothing " + name +
                      " (it is the bound of --smoothing s-constraint)");
  if (mode != Mode::Lambda)
    require(!o.lambda, "--lambda does not apply to --smoothing " + name +
                           " (it is the penalty weight of --smoothing lambda)");
  if (mode == Mode::Lambda)
    require(o.lambda.has_value(), "--smoothing lambda needs --lambda V (the penalty weight, > 0)");
  if (mode == Mode::SConstraint)
    require(noise || o.S,
            "--smoothing s-constraint needs a noise level: give --sigma V (standard deviation of "
            "the measurement noise, in the signal's units) or --weights COL (a column of "
            "per-sample standard deviations), or --S V; without any use --smoothing gcv");
  return mode;
}

int smooth(const Options& o) {
  using sid::app::require;
  // Check everything that needs no data before reading it, so a typo fails fast.
  const Mode mode = choose_mode(o);
  const bool cross_validated = mode == Mode::Gcv || mode == Mode::Cv;
  if (o.S)
    require(std::isfinite(*o.S) && *o.S >= 0.0,
            "--S must be a finite number >= 0, got " + short_number(*o.S));
  if (o.lambda)
    require(std::isfinite(*o.lambda) && *o.lambda > 0.0,
            "--lambda must be a finite number > 0, got " + short_number(*o.lambda));
  require(!o.time.empty(), "--time: empty column name");
  sid::app::ensure_writable(o.output, o.force);

  const sid::app::CsvTable table = sid::app::read_csv(o.input);
  const Eigen::VectorXd& t = table.column(o.time);
  require(table.rows() >= 2, table.source + ": smoothing needs at least 2 data rows, got " +
                                 std::to_string(table.rows()));
  require(!cross_validated || table.rows() >= 4,
          table.source + ": --smoothing " + sid::smoothing_mode_name(mode) +
              " needs at least 4 data rows, got " + std::to_string(table.rows()));
  sid::app::require_strictly_increasing(table, o.time);

  std::optional<Eigen::VectorXd> dy_column;
  if (!o.weights.empty()) {
    require(o.weights != o.time, "--weights " + o.weights + ": that is the time column");
    dy_column = table.column(o.weights);
    for (Eigen::Index i = 0; i < dy_column->size(); ++i)
      require((*dy_column)[i] > 0.0, table.where(i) + ", column '" + o.weights +
                                         "' (--weights): a standard deviation must be > 0, got " +
                                         sid::app::format_double((*dy_column)[i]));
  }

  const std::vector<std::string> signals = choose_signals(table, o);
  std::vector<double> sigma;
  if (!dy_column && !o.sigma.empty()) {
    sigma = sid::app::parse_doubles(o.sigma, "--sigma");
    require(sigma.size() == 1 || sigma.size() == signals.size(),
            "--sigma needs 1 value or " + std::to_string(signals.size()) +
                " (one per signal: " + join(signals) + "), got " + std::to_string(sigma.size()));
    for (std::size_t k = 0; k < sigma.size(); ++k)
      require(sigma[k] > 0.0, "--sigma must be > 0, got " + short_number(sigma[k]) +
                                  (sigma.size() > 1 ? " (for " + signals[k] + ")" : ""));
  }

  std::vector<std::string> names{o.time};
  std::vector<Eigen::VectorXd> columns{t};
  for (const auto& s : signals)
    for (const char* suffix : {"", "_d", "_dd"}) {
      const std::string name = s + suffix;
      for (const auto& seen : names)
        require(seen != name, "the output would have two columns named '" + name +
                                  "'; choose the signals with --signal");
      names.push_back(name);
    }

  const sid::SmoothingSpline<double> smoother(t);
  const double S = o.S ? *o.S : static_cast<double>(table.rows());
  for (std::size_t k = 0; k < signals.size(); ++k) {
    const Eigen::VectorXd& y = table.column(signals[k]);
    // One dy for the signal (1 without --sigma/--weights), unless a --weights column.
    const double dy = sigma.empty() ? 1.0 : sigma[sigma.size() == 1 ? 0 : k];
    sid::SmoothingFit<double> fit;
    bool merged = false;  // the spline's knots are not the rows
    switch (mode) {
      case Mode::SConstraint:
        fit = dy_column ? smoother.fit_constrained(y, *dy_column, S)
                        : smoother.fit_constrained(y, dy, S);
        break;
      case Mode::Lambda:
      case Mode::Gcv:
      case Mode::Cv: {
        // Samples so close that the banded system loses its digits are merged (see
        // sid/close_abscissae.hpp); the spline is still evaluated at every row.
        const auto criterion =
            mode == Mode::Gcv ? sid::SmoothingCriterion::Gcv : sid::SmoothingCriterion::Cv;
        const Eigen::VectorXd dys =
            dy_column ? *dy_column : Eigen::VectorXd::Constant(t.size(), dy);
        const sid::ScatteredFit<double> scattered = sid::fit_merging_close_abscissae<double>(
            t, y, dys,
            [&](const sid::SmoothingSpline<double>& s, const Eigen::VectorXd& ym,
                const Eigen::VectorXd& dym) {
              return mode == Mode::Lambda ? s.fit_penalized(ym, dym, 1.0 / *o.lambda)
                                          : s.fit_cross_validated(ym, dym, criterion);
            });
        fit = scattered.fit;
        merged = scattered.knots < t.size();
        if (merged && !o.quiet)
          std::cerr << kName << ": " << signals[k] << ": samples closer than "
                    << short_number(scattered.merge_tolerance) << " in " << o.time << " merged ("
                    << t.size() - scattered.knots
                    << " rows), the banded system being otherwise not numerically positive "
                       "definite\n";
        break;
      }
    }
    for (int order = 0; order <= 2; ++order)
      columns.push_back(merged ? fit.spline.evaluate(t, order)
                               : fit.spline.derivatives_at_knots(order));
    if (o.quiet) continue;
    std::cerr << kName << ": " << signals[k] << ": p = " << short_number(fit.p)
              << ", lambda = " << short_number(fit.lambda) << ", F = " << short_number(fit.F);
    if (mode == Mode::SConstraint) std::cerr << " (S = " << short_number(S) << ")";
    if (cross_validated) {
      // fit.sigma is in units of dy: with one dy per signal that is dy * sigma_hat in the
      // signal's units; with a --weights column it stays a multiple of dy.
      std::cerr << ", tr A = " << short_number(fit.trace) << ", sigma_hat = "
                << (dy_column ? short_number(fit.sigma) + " dy" : short_number(dy * fit.sigma))
                << " (" << sid::smoothing_mode_name(mode) << "), evaluations = " << fit.iterations
                << "\n";
    } else {
      std::cerr << ", iterations = " << fit.iterations << "\n";
    }
  }
  sid::app::write_csv(o.output, names, columns);
  return sid::app::kExitOk;
}

}  // namespace

int main(int argc, char** argv) {
  Options options;
  return sid::app::run_app(
      kName, kDescription, argc, argv, [&](CLI::App& cli) { define_options(cli, options); },
      [&] { return smooth(options); });
}
