#pragma once
// Counter-based random numbers for the synthetic scene engine. A draw is a pure function of
// (seed, stream, counter): no global state, so a scene depends on its seed alone and is the
// same on every machine, thread count, device and compiler. SplitMix64 finalisation (Steele et
// al.). A draw advances the counter, so two draws inside one expression whose order C++ leaves
// open (the arguments of one call, the operands of + or *) give another scene with another
// compiler (clang evaluates arguments left to right, GCC right to left): one draw a statement,
// in the order the scenes have always used (GCC's).
#include <cstdint>

namespace omnipoint::data::synth {

// 64-bit mixing function: every output bit depends on every input bit.
std::uint64_t mix64(std::uint64_t x);

class Random {
 public:
  // `stream` separates independent uses of one seed (scene layout, materials, pose...).
  Random(std::uint64_t seed, std::uint64_t stream);

  std::uint64_t next_u64();
  // Uniform in [0, 1) with 53 random bits.
  double uniform();
  double uniform(double lo, double hi);
  // Uniform integer in [lo, hi] (inclusive).
  int integer(int lo, int hi);
  bool chance(double probability);
  // -1.0 or +1.0 with equal probability.
  double choice_sign();
  // A derived 32-bit seed for per-pixel hashing (procedural textures).
  std::uint32_t seed32();

 private:
  std::uint64_t key_;
  std::uint64_t counter_ = 0;
};

}  // namespace omnipoint::data::synth
