// The Gaussian-process library's measurements (issue 33): Bayesian
// optimization of Branin (2-D) and Hartmann-6 at several budgets, medians
// and quartiles of the best value over seeds, and the cost of one fit and
// one proposal as the data grow to a few hundred points. A plain program
// (tools/bench/run.sh runs it once); gp_test asserts the short budgets.
#include <algorithm>
#include <chrono>
#include <ctime>
#include <cmath>
#include <cstdio>
#include <random>
#include <string>
#include <vector>

#include <CLI/CLI.hpp>

#include "optimizer-plugins/gp/bayes_optimizer.h"
#include "tests/optimizer-plugins/gp/test_functions.h"

namespace {

using yamor::gp::BayesOptions;

double Quantile(std::vector<double> v, double q) {
  std::sort(v.begin(), v.end());
  const double at = q * static_cast<double>(v.size() - 1);
  const auto lo = static_cast<std::size_t>(std::floor(at));
  const std::size_t hi = std::min(lo + 1, v.size() - 1);
  return v[lo] + (at - static_cast<double>(lo)) * (v[hi] - v[lo]);
}

double Seconds(std::chrono::steady_clock::time_point since) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - since).count();
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"gp_bench: Bayesian optimization of Branin and Hartmann-6, and GP fit cost"};
  int seeds = 10;
  std::vector<int> branin_budgets = {20, 30, 50};
  std::vector<int> hartmann_budgets = {40, 60, 100};
  std::vector<int> fit_sizes = {25, 50, 100, 200, 300};
  std::string acquisition = "ei";
  BayesOptions options;
  app.add_option("--seeds", seeds, "seeds per budget (medians)")->check(CLI::Range(1, 1000));
  app.add_option("--branin-budgets", branin_budgets, "evaluation budgets on Branin")->delimiter(',');
  app.add_option("--hartmann-budgets", hartmann_budgets, "evaluation budgets on Hartmann-6")->delimiter(',');
  app.add_option("--fit-sizes", fit_sizes, "data sizes of the fit timing (7 inputs)")->delimiter(',');
  app.add_option("--acquisition", acquisition, "ei or ucb")->check(CLI::IsMember({"ei", "ucb"}));
  app.add_option("--fit-restarts", options.fit_restarts, "random MAP starts per fit");
  app.add_option("--lengthscale-log-mean", options.priors.lengthscale_log_mean, "prior mean of log ℓ");
  app.add_option("--lengthscale-log-sd", options.priors.lengthscale_log_sd, "prior sd of log ℓ");
  bool fit_only = false;
  app.add_flag("--fit-only", fit_only, "only the fit timing");
  app.add_option("--noise-log-mean", options.priors.noise_log_mean, "prior mean of log σ_n²");
  CLI11_PARSE(app, argc, argv);
  if (acquisition == "ucb") options.acquisition = yamor::gp::Acquisition::kUpperConfidenceBound;

  if (fit_only) branin_budgets.clear(), hartmann_budgets.clear();
  std::printf("| function | optimum | budget | initial | median best | quartiles | median ms per proposal |\n");
  std::printf("|---|---|---|---|---|---|---|\n");
  struct Problem {
    const char* name;
    std::function<double(const Eigen::VectorXd&)> f;
    int dimension;
    int initial;
    double optimum;
    std::vector<int> budgets;
  };
  for (const Problem& p : {Problem{"Branin (negated)", yamor::gp::NegBranin, 2, 5, -0.397887, branin_budgets},
                           Problem{"Hartmann-6", yamor::gp::Hartmann6, 6, 7, 3.32237, hartmann_budgets}}) {
    for (int budget : p.budgets) {
      std::vector<double> best, per_proposal;
      for (int seed = 1; seed <= seeds; ++seed) {
        const auto started = std::chrono::steady_clock::now();
        best.push_back(yamor::gp::BestOfRun(p.f, p.dimension, p.initial, budget, static_cast<std::uint64_t>(seed), options));
        per_proposal.push_back(1e3 * Seconds(started) / std::max(1, budget - p.initial));
      }
      std::printf("| %s | %.5g | %d | %d | %.4f | %.4f .. %.4f | %.1f |\n", p.name, p.optimum, budget, p.initial,
                  Quantile(best, 0.5), Quantile(best, 0.25), Quantile(best, 0.75), Quantile(per_proposal, 0.5));
      std::fflush(stdout);
    }
  }

  // The fit and one proposal on n points of a smooth 7-input function
  // (the quadruped problem's dimension), median of 3.
  // Wall times (what a user waits) and the CPU time of the proposal (what
  // it costs on a loaded machine, which inflates wall times).
  std::printf("\n| points (7 inputs) | median fit [ms] | median proposal incl. fit [ms] | its CPU [ms] |\n|---|---|---|---|\n");
  for (int n : fit_sizes) {
    std::vector<double> fit, ask, cpu;
    for (int rep = 0; rep < 3; ++rep) {
      options.dimension = 7;
      yamor::gp::BayesianOptimizer bo(options, static_cast<std::uint64_t>(rep + 1));
      for (const Eigen::VectorXd& x : bo.InitialDesign(n)) {
        bo.Tell(x, std::sin(3.0 * x[0]) * std::cos(2.0 * x[1]) + x.tail(5).squaredNorm() - x[2] * x[3]);
      }
      const std::clock_t cpu_started = std::clock();
      bo.Ask(1);
      cpu.push_back(1e3 * static_cast<double>(std::clock() - cpu_started) / CLOCKS_PER_SEC);
      fit.push_back(1e3 * bo.last_fit_seconds());
      ask.push_back(1e3 * bo.last_ask_seconds());
    }
    std::printf("| %d | %.1f | %.1f | %.1f |\n", n, Quantile(fit, 0.5), Quantile(ask, 0.5), Quantile(cpu, 0.5));
    std::fflush(stdout);
  }
  return 0;
}
