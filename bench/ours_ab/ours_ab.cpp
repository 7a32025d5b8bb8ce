// ours_ab: two builds of ours/ in one process, answering the same batches in turn (scripts/ours_ab.sh makes
// the two sides, side.cpp compiled against two revisions of ours/include). On a shared machine, whose slow
// spells last seconds, two binaries timed one after the other differ by more than a change of a few per
// cent; batches of A and B alternating within milliseconds see the same spells, so the fastest of each
// compares them. Ranged 1-NN on Figure 3's pair and on every real pair in file order and shuffled, each
// tree, each distance; every answer of B must equal A's (squared distances, exactly), else exit 1.
#include "cli_common.hpp"
#include "nnb/datasets/catalog.hpp"
#include "nnb/datasets/manifest.hpp"
#include "timed_batches.hpp"

#include <dlfcn.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <iostream>
#include <memory>
#include <string>
#include <utility>
#include <vector>

namespace {

using nnb::InputError;

// One side: a shared object exporting side.cpp's functions.
struct Side {
  std::string path;
  void* (*build)(const char*, const double*, std::size_t) = nullptr;
  int (*answer)(void*, const double*, std::size_t, double, double*) = nullptr;
  void (*free)(void*) = nullptr;
};

template <class Fn>
void bind(void* handle, const Side& side, const char* name, Fn& fn) {
  fn = reinterpret_cast<Fn>(dlsym(handle, name));
  if (!fn) throw InputError(side.path + " has no " + name + " (not made by scripts/ours_ab.sh?)");
}

Side load_side(const std::string& path) {
  Side side{path};
  void* handle = dlopen(path.c_str(), RTLD_NOW | RTLD_LOCAL);  // local: the two sides' trees stay apart
  if (!handle) throw InputError("cannot load " + path + ": " + dlerror());
  bind(handle, side, "ours_ab_build", side.build);
  bind(handle, side, "ours_ab_answer", side.answer);
  bind(handle, side, "ours_ab_free", side.free);
  return side;
}

struct Batch {
  std::string pair, order;  // order: "file", "shuffled" or "generated"
  std::shared_ptr<const nnb::Cloud> model;
  nnb::Cloud queries;
};

// Figure 3's pair and the real pairs with files, by name.
std::vector<std::string> pair_names() {
  std::vector<std::string> all{"fig3"};
  for (const auto& pair : nnb::datasets::real_pairs()) {
    if (pair.kind == "files") all.push_back(pair.name);
  }
  return all;
}

// The batches of the pairs named (empty: every pair).
std::vector<Batch> batches(const std::vector<std::string>& names, const std::string& data_dir) {
  std::vector<Batch> out;
  nnb::datasets::DataOptions options;
  options.data_dir = data_dir;
  for (const std::string& name : pair_names()) {
    if (!names.empty() && std::find(names.begin(), names.end(), name) == names.end()) continue;
    if (name == "fig3") {
      nnb::bench::Figure3Pair fig3 = nnb::bench::figure3_pair();
      auto model = std::make_shared<const nnb::Cloud>(std::move(fig3.model));
      out.push_back({name, "generated", model, std::move(fig3.queries)});
      continue;
    }
    using nnb::datasets::Role;
    auto model = std::make_shared<const nnb::Cloud>(nnb::datasets::resolve_cloud(name, Role::model, options).points);
    nnb::Cloud scan = nnb::datasets::resolve_cloud(name, Role::query, options).points;
    out.push_back({name, "shuffled", model, nnb::bench::shuffled_scan(scan)});
    out.push_back({name, "file", model, std::move(scan)});
  }
  return out;
}

struct Timed {
  double fastest_ms = 1e300;
  std::vector<double> sq_m2;
};

void answer(const Side& side, void* index, const nnb::Cloud& queries, double max_dist_m, Timed& t) {
  t.sq_m2.assign(static_cast<std::size_t>(queries.cols()), 0.0);
  const auto start = std::chrono::steady_clock::now();
  if (side.answer(index, queries.data(), t.sq_m2.size(), max_dist_m, t.sq_m2.data()) != 0) {
    throw std::runtime_error(side.path + ": the search failed");
  }
  const std::chrono::duration<double, std::milli> took = std::chrono::steady_clock::now() - start;
  t.fastest_ms = std::min(t.fastest_ms, took.count());
}

// A side's index, freed by that side whichever way the cell ends.
using Built = std::unique_ptr<void, void (*)(void*)>;

Built build(const Side& side, const std::string& tree, const nnb::Cloud& model) {
  Built index(side.build(tree.c_str(), model.data(), static_cast<std::size_t>(model.cols())), side.free);
  if (!index) throw std::runtime_error(side.path + " could not build " + tree);
  return index;
}

// B's first answer that is not A's, as a message (empty when all are equal).
std::string first_difference(const Timed& a, const Timed& b) {
  for (std::size_t i = 0; i < a.sq_m2.size(); ++i) {
    if (a.sq_m2[i] != b.sq_m2[i]) {
      char msg[160];
      std::snprintf(msg, sizeof msg, "query %zu: A %.17g m^2, B %.17g m^2 (-1: none)", i, a.sq_m2[i], b.sq_m2[i]);
      return msg;
    }
  }
  return "";
}

struct Options {
  std::string a, b, data_dir;
  int rounds = 9;
  std::vector<std::string> pairs, trees{"kdtree", "octree"};
  std::vector<double> dists_m{0.02, 0.1};
};

// Refuses names of trees and pairs that do not exist, before any work.
void check_names(const Options& o) {
  for (const std::string& tree : o.trees) {
    if (tree != "kdtree" && tree != "octree") throw InputError("unknown tree '" + tree + "' (kdtree or octree)");
  }
  const std::vector<std::string> all = pair_names();
  for (const std::string& name : o.pairs) {
    if (std::find(all.begin(), all.end(), name) == all.end()) throw InputError("unknown pair '" + name + "'");
  }
}

int run(const Options& o) {
  check_names(o);
  const Side a = load_side(o.a), b = load_side(o.b);
  nnb::cli::warn_if_not_release(std::cerr);
  std::vector<double> ratios;
  std::printf("%-26s %-9s %-6s %6s | %10s %10s | %s\n", "pair", "queries", "tree", "d [m]", "A ms", "B ms", "B/A");
  for (const Batch& batch : batches(o.pairs, o.data_dir)) {
    for (const std::string& tree : o.trees) {
      const Built ia = build(a, tree, *batch.model);
      const Built ib = build(b, tree, *batch.model);
      for (const double d : o.dists_m) {
        Timed ta, tb;
        for (int r = 0; r < 2 * o.rounds; ++r) {  // A B B A A B ...: each side first as often
          if ((r + r / 2) % 2 == 0) answer(a, ia.get(), batch.queries, d, ta);
          else answer(b, ib.get(), batch.queries, d, tb);
        }
        const std::string diff = first_difference(ta, tb);
        if (!diff.empty()) {
          std::fprintf(stderr, "ours_ab: %s %s %s %.2f m: B's answers are not A's, %s\n", batch.pair.c_str(),
                       batch.order.c_str(), tree.c_str(), d, diff.c_str());
          return 1;
        }
        ratios.push_back(tb.fastest_ms / ta.fastest_ms);
        std::printf("%-26s %-9s %-6s %6.2f | %10.3f %10.3f | %.3f\n", batch.pair.c_str(), batch.order.c_str(),
                    tree.c_str(), d, ta.fastest_ms, tb.fastest_ms, ratios.back());
        std::fflush(stdout);
      }
    }
  }
  if (ratios.empty()) throw InputError("no cell to run");
  std::sort(ratios.begin(), ratios.end());
  std::printf("B/A over %zu cells: %.3f-%.3f, median %.3f (fastest of %d rounds each; every answer equal)\n",
              ratios.size(), ratios.front(), ratios.back(), (ratios[(ratios.size() - 1) / 2] + ratios[ratios.size() / 2]) / 2,
              o.rounds);
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  Options o;
  CLI::App app{"Two builds of ours/ (shared objects made by scripts/ours_ab.sh) timed in turn in one process, "
               "ranged 1-NN, answers checked equal."};
  app.add_option("--a", o.a, "side A (a shared object)")->required();
  app.add_option("--b", o.b, "side B (a shared object)")->required();
  app.add_option("--rounds", o.rounds, "batches of each side per cell; the fastest counts")->check(CLI::Range(1, 100000));
  app.add_option("--pairs", o.pairs, "pairs to run (fig3 and the real pairs' names; default all)")->delimiter(',');
  app.add_option("--trees", o.trees, "kdtree, octree or both (default both)")->delimiter(',');
  app.add_option("--dists", o.dists_m, "max distances, metres (default 0.02,0.1)")->delimiter(',')
      ->check(CLI::PositiveNumber);
  app.add_option("--data-dir", o.data_dir, nnb::cli::kDataDirHelp);
  if (auto code = nnb::cli::parse_command_line(app, argc, argv, "ours_ab")) return *code;
  return nnb::cli::run_reporting_errors("ours_ab", [&] { return run(o); });
}
