// fe_bench MODELS_DIR [RUNS]: end-to-end timing of the extraction on the benchmark target
// (bench_100k.stl, about 100k triangles, from `fe_make_models DIR --bench`) with the example rib as
// reference. Prints per-stage medians over RUNS runs (default 5), peak memory and the instances found,
// as a Markdown table for docs/benchmarks.md. A benchmark, not a test: it asserts nothing.
#include "featureextract/extract.h"
#include "featureextract/io.h"

#include <sys/resource.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <map>
#include <string>
#include <thread>
#include <vector>

int main(int argc, char** argv) {
  if (argc < 2) {
    std::fprintf(stderr, "usage: fe_bench MODELS_DIR [RUNS]\n");
    return 2;
  }
  const std::string dir = argv[1];
  const int runs = argc > 2 ? std::max(1, std::atoi(argv[2])) : 5;
  try {
    const auto t0 = std::chrono::steady_clock::now();
    const fe::TriangleMesh ref = fe::read_shape(dir + "/rib_reference.step");
    const fe::TriangleMesh tgt = fe::read_shape(dir + "/bench_100k.stl", fe::tessellation_for_feature(ref.diagonal()));
    const double load = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    std::map<std::string, std::vector<double>> stages;
    std::vector<std::string> order;
    std::size_t found = 0;
    fe::Result last;
    for (int r = 0; r < runs; ++r) {
      last = fe::extract(ref, tgt, fe::Params{});
      found = last.matches.size();
      for (const auto& s : last.timings) {
        if (!stages.count(s.first)) order.push_back(s.first);
        stages[s.first].push_back(s.second);
      }
      double total = 0;
      for (const auto& s : last.timings) total += s.second;
      stages["total"].push_back(total);
    }
    order.push_back("total");
    struct rusage ru;
    getrusage(RUSAGE_SELF, &ru);
    std::printf("| target | triangles | dense samples | key points | instances | threads |\n|---|---|---|---|---|---|\n");
    std::printf("| bench_100k.stl | %zu | %zu | %zu | %zu of 12 | %u |\n\n", last.target.triangles, last.target.dense_points,
                last.target.key_points, found, std::thread::hardware_concurrency());
    std::printf("| stage | median s (of %d runs) | min s | max s |\n|---|---|---|---|\n", runs);
    std::printf("| read + tessellate (once) | %.3f | | |\n", load);
    for (const auto& name : order) {
      auto v = stages[name];
      std::sort(v.begin(), v.end());
      std::printf("| %s | %.3f | %.3f | %.3f |\n", name.c_str(), v[v.size() / 2], v.front(), v.back());
    }
    std::printf("\npeak resident memory: %.0f MB\n", ru.ru_maxrss / 1024.0);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "fe_bench: %s\n", e.what());
    return 3;
  }
  return 0;
}
