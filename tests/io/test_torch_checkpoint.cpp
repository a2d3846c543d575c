// The PyTorch checkpoint reader on hand-built files (tests/support/torch_pickle.h): the zip
// container, the restricted unpickler, tensors with offsets and strides, the weights layouts,
// and every refusal. Checkpoints written by PyTorch itself: test_torch_checkpoint_python.cpp.
#include "omnipoint/io/torch_checkpoint.h"

#include <ATen/ATen.h>
#include <gtest/gtest.h>

#include <cstring>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <string>

#include "omnipoint/io/pickle.h"
#include "omnipoint/io/zip_archive.h"
#include "support/expect_error.h"
#include "support/scratch_dir.h"
#include "support/torch_pickle.h"

namespace fs = std::filesystem;
using omnipoint::io::PickleValue;
using omnipoint::test::checkpoint_zip;
using omnipoint::test::expect_error;
using omnipoint::test::pkl_global;
using omnipoint::test::pkl_int;
using omnipoint::test::pkl_ordered_dict;
using omnipoint::test::pkl_state_dict;
using omnipoint::test::pkl_str;
using omnipoint::test::pkl_tensor;

namespace {

using Kind = PickleValue::Kind;

std::string bytes_of(const at::Tensor& tensor) {
  const at::Tensor t = tensor.contiguous();
  return std::string(static_cast<const char*>(t.data_ptr()), t.numel() * t.element_size());
}

PickleValue parse(const std::string& bytes) {
  return omnipoint::io::parse_torch_checkpoint(bytes.data(), bytes.size(), "case.pt");
}

// A pickle unpickled with no storages to serve.
PickleValue unpickle(const std::string& pickle) {
  return omnipoint::io::unpickle(
      pickle.data(), pickle.size(),
      [](const omnipoint::io::StorageRequest&) -> at::Tensor {
        throw std::runtime_error("no storages here");
      },
      "case.pkl");
}

void expect_checkpoint_error(const std::string& bytes, const std::vector<std::string>& parts) {
  std::vector<std::string> with_source = parts;
  with_source.emplace_back("case.pt");
  expect_error<std::runtime_error>([&] { parse(bytes); }, with_source);
}

void expect_pickle_error(const std::string& pickle, const std::vector<std::string>& parts) {
  SCOPED_TRACE(parts.front());
  std::vector<std::string> with_source = parts;
  with_source.emplace_back("case.pkl");
  expect_error<std::runtime_error>([&] { unpickle(pickle); }, with_source);
}

const std::string kProto = std::string("\x80\x02", 2);

}  // namespace

TEST(TorchCheckpoint, StateDictWithOffsetsStridesAndSharedStorage) {
  const at::Tensor floats = at::arange(24, at::kFloat);
  const at::Tensor longs = at::arange(-3, 5, at::kLong);
  const std::string pickle = pkl_state_dict({
      {"plain", pkl_tensor("0", "FloatStorage", 24, 0, {2, 3}, {3, 1})},
      {"offset", pkl_tensor("0", "FloatStorage", 24, 10, {4}, {1})},
      {"transposed", pkl_tensor("0", "FloatStorage", 24, 0, {4, 6}, {1, 4})},  // non-contiguous
      {"scalar", pkl_tensor("0", "FloatStorage", 24, 23, {}, {})},
      {"empty", pkl_tensor("0", "FloatStorage", 24, 24, {0, 5}, {5, 1})},
      {"longs", pkl_tensor("1", "LongStorage", 8, 2, {2, 2}, {1, 2})},
  });
  const std::string file =
      checkpoint_zip(pickle, {{"0", bytes_of(floats)}, {"1", bytes_of(longs)}});
  const PickleValue root = parse(file);
  ASSERT_TRUE(root.is(Kind::kDict));
  ASSERT_EQ(root.keys().size(), 6u);
  EXPECT_EQ(root.keys()[0].as_string(), "plain");  // insertion order (an OrderedDict)
  EXPECT_TRUE(at::equal(root.find("plain")->as_tensor(), floats.narrow(0, 0, 6).view({2, 3})));
  EXPECT_TRUE(at::equal(root.find("offset")->as_tensor(), floats.narrow(0, 10, 4)));
  const at::Tensor transposed = root.find("transposed")->as_tensor();
  EXPECT_FALSE(transposed.is_contiguous());
  EXPECT_TRUE(at::equal(transposed, floats.view({6, 4}).t()));
  EXPECT_EQ(root.find("scalar")->as_tensor().dim(), 0);
  EXPECT_EQ(root.find("scalar")->as_tensor().item<float>(), 23.0f);
  EXPECT_EQ(root.find("empty")->as_tensor().sizes(), (std::vector<int64_t>{0, 5}));
  EXPECT_TRUE(at::equal(root.find("longs")->as_tensor(), longs.narrow(0, 2, 4).view({2, 2}).t()));

  // As weights: a bare state dict, contiguous, floats converted on request.
  const fs::path dir = omnipoint::test::fresh_process_dir("omnipoint_torch_checkpoint");
  std::ofstream((dir / "state.pth").string(), std::ios::binary) << file;
  const omnipoint::io::WeightsFile weights =
      omnipoint::io::read_weights((dir / "state.pth").string());
  EXPECT_EQ(weights.metadata, (std::map<std::string, std::string>{{"format", "state_dict"}}));
  EXPECT_TRUE(weights.tensors.at("transposed").is_contiguous());
  EXPECT_TRUE(at::equal(weights.tensors.at("transposed"), floats.view({6, 4}).t()));
  EXPECT_EQ(weights.tensors.at("longs").scalar_type(), at::kLong);
  const auto doubles = omnipoint::io::read_weights((dir / "state.pth").string(), at::kDouble);
  EXPECT_EQ(doubles.tensors.at("plain").scalar_type(), at::kDouble);
  // Tensors of a mapped file are writable copies-on-write: the file does not change.
  weights.tensors.at("plain").fill_(-1);
  EXPECT_EQ(omnipoint::test::slurp(dir / "state.pth"), file);
  fs::remove_all(dir);
}

TEST(TorchCheckpoint, EveryStorageDtype) {
  const std::pair<const char*, at::ScalarType> types[] = {
      {"FloatStorage", at::kFloat},       {"HalfStorage", at::kHalf},
      {"BFloat16Storage", at::kBFloat16}, {"DoubleStorage", at::kDouble},
      {"LongStorage", at::kLong},         {"IntStorage", at::kInt},
      {"ShortStorage", at::kShort},       {"CharStorage", at::kChar},
      {"ByteStorage", at::kByte},         {"BoolStorage", at::kBool}};
  std::vector<std::pair<std::string, std::string>> items, storages;
  std::map<std::string, at::Tensor> expected;
  int key = 0;
  for (const auto& [storage, dtype] : types) {
    const at::Tensor t =
        dtype == at::kBool ? at::arange(6) % 2 == 0 : (at::arange(6, at::kDouble) * 1.5).to(dtype);
    expected[storage] = t;
    items.emplace_back(storage, pkl_tensor(std::to_string(key), storage, 6, 0, {6}, {1}));
    storages.emplace_back(std::to_string(key++), bytes_of(t));
  }
  const PickleValue root = parse(checkpoint_zip(pkl_state_dict(items), storages));
  for (const auto& [name, tensor] : expected) {
    SCOPED_TRACE(name);
    EXPECT_EQ(root.find(name)->as_tensor().scalar_type(), tensor.scalar_type());
    EXPECT_TRUE(at::equal(root.find(name)->as_tensor(), tensor));
  }
}

TEST(TorchCheckpoint, BoolBytesOtherThanZeroOrOneAreTrue) {
  const PickleValue root =
      parse(checkpoint_zip(pkl_state_dict({{"b", pkl_tensor("0", "BoolStorage", 3, 0, {3}, {1})}}),
                           {{"0", std::string("\x00\x07\x01", 3)}}));
  EXPECT_TRUE(at::equal(root.find("b")->as_tensor(),
                        at::tensor(std::vector<int64_t>{0, 1, 1}).to(at::kBool)));
}

TEST(TorchCheckpoint, NestedValuesAndMoGeLayout) {
  // {'model_config': {'encoder': {'backbone': 'x', 'layers': [1, 2.5, None, True]}, 't': (1,)},
  //  'model': OrderedDict(w=tensor)} with a BUILD of the state dict's _metadata.
  const std::string config = "}(" + pkl_str("encoder") + "}(" + pkl_str("backbone") + pkl_str("x") +
                             pkl_str("layers") + "](" + pkl_int(1) + "G" +
                             std::string("\x40\x04\x00\x00\x00\x00\x00\x00", 8) + "N\x88" + "eu" +
                             pkl_str("t") + pkl_int(1) + "\x85" + "u";
  const std::string model = pkl_ordered_dict() + "(" + pkl_str("w") +
                            pkl_tensor("0", "FloatStorage", 2, 0, {2}, {1}) + "u}(" +
                            pkl_str("_metadata") + "}u" + "b";
  const std::string pickle =
      kProto + "}(" + pkl_str("model_config") + config + pkl_str("model") + model + "u.";
  const PickleValue root =
      parse(checkpoint_zip(pickle, {{"0", bytes_of(at::tensor({1.5f, -2.0f}))}}));
  const PickleValue& layers = *root.find("model_config")->find("encoder")->find("layers");
  ASSERT_TRUE(layers.is(Kind::kList));
  EXPECT_EQ(layers.items()[1].as_float(), 2.5);
  EXPECT_TRUE(layers.items()[2].is(Kind::kNone));
  EXPECT_TRUE(layers.items()[3].as_bool());
  EXPECT_TRUE(root.find("model_config")->find("t")->is(Kind::kTuple));

  const omnipoint::io::WeightsFile weights = omnipoint::io::checkpoint_weights(root, "case.pt");
  EXPECT_EQ(weights.metadata.at("format"), "moge2");
  EXPECT_EQ(nlohmann::json::parse(weights.metadata.at("config")),
            nlohmann::json::parse(
                R"({"encoder": {"backbone": "x", "layers": [1, 2.5, null, true]}, "t": [1]})"));
  EXPECT_TRUE(at::equal(weights.tensors.at("w"), at::tensor({1.5f, -2.0f})));
}

TEST(TorchCheckpoint, LayoutsThatAreNotWeights) {
  const auto weights_of = [](const std::string& pickle) {
    return omnipoint::io::checkpoint_weights(unpickle(pickle), "case.pt");
  };
  expect_error<std::runtime_error>(
      [&] {
        weights_of(kProto +
                   "](K\x01K\x02"
                   "e.");
      },
      {"case.pt", "holds a list, not a dict of weights"});
  expect_error<std::runtime_error>(
      [&] { weights_of(kProto + "}(" + pkl_str("model") + "}" + "u."); },
      {"case.pt", "'model' but no 'model_config'"});
  expect_error<std::runtime_error>(
      [&] { weights_of(kProto + "}(" + pkl_str("epoch") + pkl_int(3) + "u."); },
      {"case.pt", "neither MoGe's", "top-level keys: epoch"});
  expect_error<std::runtime_error>(
      [&] {
        weights_of(kProto + "}(" + pkl_str("model_config") + "}" + pkl_str("model") + "}(" +
                   pkl_str("w") + pkl_int(1) + "uu.");
      },
      {"case.pt", "'model' entry 'w' is a int, not a tensor"});
}

TEST(TorchCheckpoint, RefusesEveryOtherGlobalWithOneLine) {
  // What a malicious pickle calls: os.system("..."), builtins.eval("...").
  expect_pickle_error(kProto + pkl_global("os", "system") + "(" + pkl_str("touch pwned") + "tR.",
                      {"refuses the pickled global 'os.system'"});
  expect_pickle_error(kProto + pkl_global("builtins", "eval") + "(" + pkl_str("1+1") + "tR.",
                      {"refuses the pickled global 'builtins.eval'"});
  expect_pickle_error(kProto + pkl_str("posix") + pkl_str("system") + "\x93.",
                      {"refuses the pickled global 'posix.system'"});
  expect_pickle_error(kProto + pkl_global("numpy.core.multiarray", "_reconstruct") + ".",
                      {"'numpy.core.multiarray._reconstruct'"});
  // torch's own callables beyond the tensor rebuilders are refused too.
  expect_pickle_error(kProto + pkl_global("torch", "load") + ".", {"'torch.load'"});
  // A storage dtype outside the list (complex), named as such.
  expect_pickle_error(kProto + pkl_global("torch", "ComplexFloatStorage") + ".",
                      {"storage type torch.ComplexFloatStorage is not supported"});
  // Control characters in a name are not printed.
  expect_pickle_error(kProto + pkl_global("a\rb", "c") + ".", {"'a?b.c'"});
}

TEST(TorchCheckpoint, MalformedPicklesFailWithOneLine) {
  expect_pickle_error(kProto + "}", {"ends without a STOP opcode"});
  expect_pickle_error(kProto + "X" + std::string("\xff\x00\x00\x00", 4) + "ab", {"runs past"});
  expect_pickle_error(std::string("\x80\x09", 2), {"pickle protocol 9"});
  expect_pickle_error(kProto + "u.", {"no MARK"});
  expect_pickle_error(kProto + ".", {"pops from an empty stack"});
  expect_pickle_error(kProto + "h\x05.", {"memo entry 5"});
  expect_pickle_error(kProto + "\x81.", {"unsupported pickle opcode 0x81"});
  expect_pickle_error(kProto + "\x8a\x09" + std::string(9, '\x01') + ".", {"wider than 64 bits"});
  expect_pickle_error(kProto + "}(]K\x01u.", {"a dict key of type list"});
  expect_pickle_error(kProto +
                          "K\x01(K\x02"
                          "e.",
                      {"APPEND to a int"});
  // A list that contains itself, and lists nested past the limit.
  expect_pickle_error(kProto + std::string("]q\0h\0a.", 7), {"nest deeper than"});
  std::string deep = kProto;
  for (int i = 0; i < 100; ++i) deep += "]";
  for (int i = 0; i < 99; ++i) deep += "a";
  expect_pickle_error(deep + ".", {"nest deeper than 64"});
  // Shared sub-lists doubling 40 times would be 2^40 values.
  std::string doubling = kProto + "]";
  for (int i = 0; i < 40; ++i) doubling += "2\x86";
  expect_pickle_error(doubling + ".", {"expand beyond"});
}

TEST(TorchCheckpoint, IntegersFloatsAndKeysAsPythonHasThem) {
  // LONG1 of 8 bytes (-2^63), BININT2, a negative BININT, BINFLOAT; True and 1 are one key.
  const std::string pickle = kProto + "}(" + pkl_str("a") + "\x8a\x08" + std::string(7, '\0') +
                             "\x80" + pkl_str("b") + "M\x34\x12" + pkl_str("c") + pkl_int(-7) +
                             "K\x01" + pkl_str("one") + "\x88" + pkl_str("true") + "u.";
  const PickleValue root = unpickle(pickle);
  EXPECT_EQ(root.find("a")->as_int(), std::numeric_limits<int64_t>::min());
  EXPECT_EQ(root.find("b")->as_int(), 0x1234);
  EXPECT_EQ(root.find("c")->as_int(), -7);
  ASSERT_EQ(root.keys().size(), 4u);
  EXPECT_EQ(root.keys()[3].as_int(), 1);
  EXPECT_EQ(root.values()[3].as_string(), "true");
}

TEST(TorchCheckpoint, TensorsMustLieInsideTheirStorage) {
  const auto with = [](const std::string& tensor, const std::string& bytes) {
    return checkpoint_zip(pkl_state_dict({{"w", tensor}}), {{"0", bytes}});
  };
  const std::string six = bytes_of(at::zeros({6}));
  expect_checkpoint_error(with(pkl_tensor("0", "FloatStorage", 6, 0, {7}, {1}), six),
                          {"reaches past the end of its storage"});
  expect_checkpoint_error(with(pkl_tensor("0", "FloatStorage", 6, 4, {2, 2}, {1, 1}), six),
                          {"reaches past the end of its storage"});
  expect_checkpoint_error(with(pkl_tensor("0", "FloatStorage", 6, 7, {0}, {1}), six),
                          {"storage offset lies outside"});
  expect_checkpoint_error(with(pkl_tensor("0", "FloatStorage", 6, 0, {2}, {-1}), six),
                          {"negative size or stride"});
  expect_checkpoint_error(with(pkl_tensor("0", "FloatStorage", 6, 0, {1000, 1000}, {0, 0}), six),
                          {"more elements than its storage"});
  // The storage record is shorter than the pickle says.
  expect_checkpoint_error(with(pkl_tensor("0", "FloatStorage", 7, 0, {7}, {1}), six),
                          {"storage '0' holds 24 bytes"});
  // A storage without its record.
  expect_checkpoint_error(
      checkpoint_zip(pkl_state_dict({{"w", pkl_tensor("9", "FloatStorage", 1, 0, {1}, {1})}}), {}),
      {"storage '9' has no record archive/data/9"});
}

TEST(TorchCheckpoint, ZipProblemsFailWithOneLine) {
  const std::string good =
      checkpoint_zip(pkl_state_dict({{"w", pkl_tensor("0", "FloatStorage", 6, 0, {6}, {1})}}),
                     {{"0", bytes_of(at::ones({6}))}});
  EXPECT_NO_THROW(parse(good));
  // Truncated anywhere: the end record (or what it points at) is gone.
  for (const std::size_t keep : {good.size() - 1, good.size() / 2, std::size_t{30}, std::size_t{4}})
    expect_checkpoint_error(good.substr(0, keep), {"not a readable zip archive"});
  // Not a zip at all, a zip without data.pkl, a TorchScript archive.
  expect_checkpoint_error("hello", {"not a PyTorch checkpoint (torch.save writes a zip"});
  expect_checkpoint_error(omnipoint::test::stored_zip({{"a/b.txt", "x"}}), {"no data.pkl"});
  expect_checkpoint_error(
      omnipoint::test::stored_zip({{"m/constants.pkl", "x"}, {"m/code/m.py", "x"}}),
      {"TorchScript archive"});
  // A big-endian checkpoint.
  expect_checkpoint_error(omnipoint::test::stored_zip(
                              {{"archive/data.pkl", kProto + "N."}, {"archive/byteorder", "big"}}),
                          {"byte order 'big'"});
  // A compressed record (method 8) is named as such.
  std::string deflated = omnipoint::test::stored_zip({{"archive/data.pkl", kProto + "N."}});
  deflated[8] = 8;  // the local header's method: still stored in the central directory ...
  const std::size_t central = deflated.find(std::string("PK\x01\x02", 4));
  deflated[central + 10] = 8;  // ... and now deflated there too
  expect_checkpoint_error(deflated, {"entry 'archive/data.pkl' is compressed (method 8)"});
}

TEST(TorchCheckpoint, RefusesTheLegacyFormatSayingHowToResave) {
  // The pre-1.6 format starts with its pickled magic number.
  const std::string legacy =
      kProto + "\x8a\x0a" + std::string("\x6c\xfc\x9c\x46\xf9\x20\x6a\xa8\x50\x19", 10) + ".";
  expect_checkpoint_error(legacy, {"pre-1.6 format", "torch.save"});
  const fs::path dir = omnipoint::test::fresh_process_dir("omnipoint_torch_legacy");
  std::ofstream((dir / "old.pt").string(), std::ios::binary) << legacy;
  expect_error<std::runtime_error>([&] { omnipoint::io::read_weights((dir / "old.pt").string()); },
                                   {(dir / "old.pt").string(), "pre-1.6 format", "re-save it"});
  fs::remove_all(dir);
}

TEST(TorchCheckpoint, Zip64SizesAreRead) {
  // The central directory's offset in the zip64 end record (0xFFFFFFFF in the classic one).
  const std::string pickle =
      pkl_state_dict({{"w", pkl_tensor("0", "FloatStorage", 2, 0, {2}, {1})}});
  std::string zip = checkpoint_zip(pickle, {{"0", bytes_of(at::tensor({3.0f, 4.0f}))}});
  const std::size_t end = zip.rfind(std::string("PK\x05\x06", 4));
  const std::string directory_at = zip.substr(end + 16, 4),
                    directory_size = zip.substr(end + 12, 4);
  std::uint64_t at = 0, size = 0;
  std::memcpy(&at, directory_at.data(), 4);
  std::memcpy(&size, directory_size.data(), 4);
  std::string classic_end = zip.substr(end);
  classic_end.replace(16, 4, std::string(4, '\xff'));
  zip.resize(end);
  const std::size_t zip64_end = zip.size();
  using omnipoint::test::le;
  zip += le(0x06064b50, 4) + le(44, 8) + le(45, 2) + le(45, 2) + le(0, 4) + le(0, 4) + le(3, 8) +
         le(3, 8) + le(size, 8) + le(at, 8);
  zip += le(0x07064b50, 4) + le(0, 4) + le(zip64_end, 8) + le(1, 4);
  zip += classic_end;
  EXPECT_TRUE(at::equal(parse(zip).find("w")->as_tensor(), at::tensor({3.0f, 4.0f})));
}
