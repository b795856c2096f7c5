// CGAL's one-shot (read + preprocess + iterations) in a process of its own: this benchmark
// started again in a child mode (kCgalOneShotFlag), its heap set up as the diffreg tool's and
// timed inside it, without its start and exit. Inside the benchmark's own process the time
// depends on what ran before (the generated 10K sphere: 55 ms after the other one-shot cases,
// 96 ms alone) and on glibc's default heap, which maps and clears CGAL's large blocks afresh:
// the rocker arm's 1 iteration took 84-133 ms there against 64-76 ms in a process of its own.
#include <diffreg/core/error.h>
#include <diffreg/core/heap.h>
#include "bench.h"

#include <cstdio>
#include <fstream>
#include <string>
#include <vector>

namespace diffreg::bench {

double cgalOneShotInChild(const std::string& path, const std::vector<int>& handles,
                          const Eigen::MatrixXd& targets, int iterations,
                          const std::filesystem::path& scratchDir) {
  // The handles and their targets: "count", then "vertex x y z" per handle.
  const std::string targetFile = (scratchDir / "cgal-targets.txt").string();
  {
    std::ofstream file(targetFile);
    file.precision(17);
    file << handles.size() << "\n";
    for (size_t i = 0; i < handles.size(); ++i) {
      const Eigen::Index r = static_cast<Eigen::Index>(i);
      file << handles[i] << " " << targets(r, 0) << " " << targets(r, 1) << " " << targets(r, 2)
           << "\n";
    }
    if (!file) throw IoError("CGAL peer: cannot write " + targetFile);
  }
  const std::string output = runSelf(
      {kCgalOneShotFlag, path, targetFile, std::to_string(iterations)}, "CGAL peer on " + path);
  if (output.empty()) throw Error("CGAL peer: its process printed no time for " + path);
  return std::stod(output);
}

int runCgalOneShotChild(const std::string& path, const std::string& targetFile, int iterations) {
  // The heap set up as the diffreg tool's (huge pages, large blocks kept), which CGAL gains from
  // as well; plain C reading, so that the heap is as fresh as the tool's when CGAL starts.
  tuneHeapForBatchRun();
  std::FILE* file = std::fopen(targetFile.c_str(), "r");
  if (!file) throw IoError("cannot open " + targetFile);
  long count = 0;
  if (std::fscanf(file, "%ld", &count) != 1 || count <= 0 || count > 100000000) {
    std::fclose(file);
    throw IoError("bad target file " + targetFile);
  }
  std::vector<int> handles(static_cast<size_t>(count));
  Eigen::MatrixXd targets(count, 3);
  for (long i = 0; i < count; ++i) {
    if (std::fscanf(file, "%d %lf %lf %lf", &handles[static_cast<size_t>(i)], &targets(i, 0),
                    &targets(i, 1), &targets(i, 2)) != 4) {
      std::fclose(file);
      throw IoError("bad target file " + targetFile);
    }
  }
  std::fclose(file);
  std::printf("%.9f\n", cgalOneShot(path, handles, targets, iterations));
  return 0;
}

}  // namespace diffreg::bench
