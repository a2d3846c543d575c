#include "omnipoint/data/synth/random.h"

namespace omnipoint::data::synth {

std::uint64_t mix64(std::uint64_t x) {
  x += 0x9E3779B97F4A7C15ULL;
  x = (x ^ (x >> 30)) * 0xBF58476D1CE4E5B9ULL;
  x = (x ^ (x >> 27)) * 0x94D049BB133111EBULL;
  return x ^ (x >> 31);
}

Random::Random(std::uint64_t seed, std::uint64_t stream) : key_(mix64(mix64(seed) ^ stream)) {}

std::uint64_t Random::next_u64() {
  return mix64(key_ + counter_++ * 0xD1B54A32D192ED03ULL);
}

double Random::uniform() {
  return static_cast<double>(next_u64() >> 11) * 0x1.0p-53;
}

double Random::uniform(double lo, double hi) {
  return lo + (hi - lo) * uniform();
}

int Random::integer(int lo, int hi) {
  const auto span = static_cast<std::uint64_t>(static_cast<std::int64_t>(hi) - lo + 1);
  return lo + static_cast<int>(next_u64() % span);
}

bool Random::chance(double probability) {
  return uniform() < probability;
}

double Random::choice_sign() {
  return chance(0.5) ? 1.0 : -1.0;
}

std::uint32_t Random::seed32() {
  return static_cast<std::uint32_t>(next_u64() >> 32);
}

}  // namespace omnipoint::data::synth
