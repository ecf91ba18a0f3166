// libFuzzer target: the nodelet's sweep path (sweep_path.h) on fuzz bytes. Every input must
// end in a result with one label per point or a refusal; a crash, a sanitizer report, another
// exception or a hang (-timeout) is a finding.
#include <cstdint>
#include <cstdlib>

#include "sweep_path.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const auto out = novelty_detection::fuzz::runSweepPath(data, size);
  if (out.kind == novelty_detection::fuzz::SweepOutcome::kResult &&
      out.result.labels.size() != out.sweep.size())
    std::abort();
  return 0;
}
