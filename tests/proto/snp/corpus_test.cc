// Keeps the checked-in libFuzzer seed corpus of snp_decoder_fuzzer in step
// with the codec: every seed must still hold the frames it was written with.
// Regenerate: YAMOR_WRITE_SNP_CORPUS=1 snp_test --gtest_filter=SnpFuzzCorpus*
// (writes into the source tree).
#include <gtest/gtest.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <map>
#include <random>
#include <string>
#include <vector>

#include "proto/snp/snp.h"
#include "tests/proto/snp/test_messages.h"

namespace yamor::snp {
namespace {

namespace fs = std::filesystem;

const fs::path kCorpusDir =
    fs::path(YAMOR_SOURCE_DIR) / "tests/fuzz/corpus/snp_decoder_fuzzer";

// A seed: the first byte drives the fuzzer's chunk sizes, then the stream.
struct Seed {
  std::string name;
  uint8_t chunk_seed = 0;
  std::vector<uint8_t> stream;
  std::size_t frames = 0;  // frames the stream holds
};

void AddFrame(Seed& seed, const testing::AddressedMessage& message) {
  const std::vector<uint8_t> bytes = testing::EncodeMessage(message);
  seed.stream.insert(seed.stream.end(), bytes.begin(), bytes.end());
  ++seed.frames;
}

std::vector<Seed> Seeds() {
  std::vector<Seed> seeds;
  Seed module{"module_messages", 3, {}, 0};
  Seed bridge{"bridge_messages", 17, {}, 0};
  for (const auto& sample : testing::SampleMessages()) {
    AddFrame(ClassOf(TypeOf(sample.message)) == MessageClass::kModule ? module : bridge,
             sample);
  }
  seeds.push_back(module);
  seeds.push_back(bridge);

  Seed single{"single_set_oscillator", 0, {}, 0};
  AddFrame(single, {Address::Host(), Address::Module(3), SetOscillator{0.5f, 0.0f, 1.0f}});
  seeds.push_back(single);

  Seed garbage{"garbage_then_frames", 200, {}, 0};
  std::mt19937_64 rng(1);
  for (int i = 0; i < 40; ++i) {
    garbage.stream.push_back(i % 5 == 0 ? kStartByte : static_cast<uint8_t>(rng()));
  }
  AddFrame(garbage, {Address::Host(), Address::Bridge(), Step{0.01}});
  garbage.stream.insert(garbage.stream.end(), {kStartByte, 64, 0x06, 0, 0, 0x63});
  AddFrame(garbage, {Address::Module(2), Address::Host(), ServoAngle{0.25f}});
  seeds.push_back(garbage);

  Seed truncated{"frames_then_truncated", 91, {}, 0};
  AddFrame(truncated, {Address::Bridge(), Address::Host(), SimTime{3.5}});
  AddFrame(truncated, {Address::Host(), Address::Broadcast(), Control{Tristate::kOn, Tristate::kOn, Tristate::kOn}});
  const std::vector<uint8_t> cut = testing::EncodeMessage(
      {Address::Host(), Address::Module(1), SetCoupling{2, 1.5f, 1.0f}});
  truncated.stream.insert(truncated.stream.end(), cut.begin(), cut.end() - 3);
  seeds.push_back(truncated);
  return seeds;
}

TEST(SnpFuzzCorpusTest, SeedsHoldTheirFrames) {
  const std::vector<Seed> seeds = Seeds();
  if (std::getenv("YAMOR_WRITE_SNP_CORPUS") != nullptr) {
    fs::create_directories(kCorpusDir);
    for (const Seed& seed : seeds) {
      std::ofstream out(kCorpusDir / seed.name, std::ios::binary);
      out.put(static_cast<char>(seed.chunk_seed));
      out.write(reinterpret_cast<const char*>(seed.stream.data()),
                static_cast<std::streamsize>(seed.stream.size()));
    }
  }
  for (const Seed& seed : seeds) {
    SCOPED_TRACE(seed.name);
    std::ifstream in(kCorpusDir / seed.name, std::ios::binary);
    ASSERT_TRUE(in) << "missing seed " << (kCorpusDir / seed.name)
                    << " (regenerate with YAMOR_WRITE_SNP_CORPUS=1)";
    const std::vector<uint8_t> file((std::istreambuf_iterator<char>(in)),
                                    std::istreambuf_iterator<char>());
    ASSERT_FALSE(file.empty());
    EXPECT_EQ(file[0], seed.chunk_seed);
    EXPECT_EQ(std::vector<uint8_t>(file.begin() + 1, file.end()), seed.stream)
        << "seed is stale (regenerate with YAMOR_WRITE_SNP_CORPUS=1)";
    FrameDecoder decoder;
    std::vector<DecodeEvent> events;
    decoder.Feed(std::span(file).subspan(1), events);
    decoder.Flush(events);
    EXPECT_EQ(decoder.stats().frames, seed.frames);
  }
}

}  // namespace
}  // namespace yamor::snp
