#include <ATen/ATen.h>
#include <gtest/gtest.h>

#include <cstdint>
#include <filesystem>
#include <nlohmann/json.hpp>
#include <string>

#include "omnipoint/io/atomic_file.h"
#include "omnipoint/io/safetensors.h"
#include "omnipoint/io/torch_checkpoint.h"

namespace fs = std::filesystem;
using omnipoint::io::encode_safetensors;
using omnipoint::io::parse_safetensors;
using omnipoint::io::read_safetensors;
using omnipoint::io::SafetensorsFile;
using omnipoint::io::write_safetensors;

namespace {

const std::string kFixture =
    std::string(OMNIPOINT_FIXTURE_DIR) + "/moge2_forward_a/model.safetensors";

// A file from a header text and a data section, exactly as given (no padding).
std::string make_file(const std::string& header, const std::string& data = "") {
  std::string out(8, '\0');
  for (int i = 0; i < 8; ++i)
    out[i] = static_cast<char>((uint64_t{header.size()} >> (8 * i)) & 0xff);
  return out + header + data;
}

void expect_parse_error(const std::string& bytes, const std::string& fragment) {
  try {
    parse_safetensors(bytes.data(), bytes.size(), "case.safetensors");
    FAIL() << "expected an error containing '" << fragment << "'";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find(fragment), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("case.safetensors"), std::string::npos) << e.what();
  }
}

fs::path fresh_dir(const std::string& name) {
  const fs::path dir = fs::temp_directory_path() / name;
  fs::remove_all(dir);
  fs::create_directories(dir);
  return dir;
}

}  // namespace

TEST(Safetensors, RoundTripEveryDtype) {
  const at::ScalarType types[] = {at::kDouble, at::kFloat, at::kHalf, at::kBFloat16, at::kLong,
                                  at::kInt,    at::kShort, at::kChar, at::kByte,     at::kBool};
  std::map<std::string, at::Tensor> tensors;
  for (auto type : types) {
    at::Tensor t = (at::randn({3, 4, 5}, at::kDouble) * 50).to(type);
    if (type == at::kBool) t = at::rand({3, 4, 5}) > 0.5;
    tensors[std::string("t_") + c10::toString(type)] = t;
  }
  tensors["scalar"] = at::scalar_tensor(1.5, at::kFloat);
  tensors["empty"] = at::zeros({0, 7}, at::kHalf);
  const std::string bytes =
      encode_safetensors(tensors, {{"format", "test"}, {"b", "\"quoted\"\n"}});
  const SafetensorsFile back = parse_safetensors(bytes.data(), bytes.size(), "roundtrip");
  ASSERT_EQ(back.tensors.size(), tensors.size());
  for (const auto& [name, t] : tensors) {
    const at::Tensor& b = back.tensors.at(name);
    EXPECT_EQ(b.scalar_type(), t.scalar_type()) << name;
    EXPECT_EQ(b.sizes(), t.sizes()) << name;
    EXPECT_TRUE(at::equal(b, t)) << name;
  }
  EXPECT_EQ(back.metadata.at("format"), "test");
  EXPECT_EQ(back.metadata.at("b"), "\"quoted\"\n");
}

TEST(Safetensors, FixtureLoads) {
  const SafetensorsFile file = read_safetensors(kFixture);
  EXPECT_EQ(file.tensors.size(), 203u);
  EXPECT_EQ(file.metadata.at("format"), "moge2");
  const auto config = nlohmann::json::parse(file.metadata.at("config"));
  const int width = config["encoder"]["backbone_config"]["embed_dim"].get<int>();
  EXPECT_EQ(file.tensors.at("encoder.image_mean").sizes(), (at::IntArrayRef{1, 3, 1, 1}));
  EXPECT_EQ(file.tensors.at("encoder.backbone.pos_embed").sizes(),
            (at::IntArrayRef{1, 1370, width}));
  EXPECT_EQ(file.tensors.at("encoder.backbone.blocks.0.attn.qkv.weight").sizes(),
            (at::IntArrayRef{int64_t{3} * width, width}));
  for (const auto& [name, t] : file.tensors) {
    EXPECT_EQ(t.scalar_type(), at::kFloat) << name;
    EXPECT_TRUE(t.is_contiguous()) << name;
  }
  // ImageNet normalisation constants, stored as float32.
  const at::Tensor mean = file.tensors.at("encoder.image_mean").flatten();
  EXPECT_FLOAT_EQ(mean[0].item<float>(), 0.485f);
  EXPECT_FLOAT_EQ(mean[2].item<float>(), 0.406f);
}

TEST(Safetensors, FixtureReencodesToTheSameData) {
  const std::string original = omnipoint::io::read_file(kFixture);
  const SafetensorsFile file = parse_safetensors(original.data(), original.size(), kFixture);
  const std::string again = encode_safetensors(file.tensors, file.metadata);
  // Same data section (single dtype: name order); the header holds the same JSON.
  const auto header_size = [](const std::string& s) {
    uint64_t n = 0;
    for (int i = 7; i >= 0; --i) n = (n << 8) | static_cast<unsigned char>(s[i]);
    return n;
  };
  const uint64_t n0 = header_size(original), n1 = header_size(again);
  EXPECT_EQ(original.substr(8 + n0), again.substr(8 + n1));
  EXPECT_EQ(nlohmann::json::parse(original.substr(8, n0)),
            nlohmann::json::parse(again.substr(8, n1)));
}

TEST(Safetensors, WriteAndReadWithConversion) {
  const fs::path dir = fresh_dir("omnipoint_safetensors_convert");
  const std::string path = (dir / "w.safetensors").string();
  const at::Tensor w = at::randn({4, 6});
  const at::Tensor steps = at::arange(5, at::kLong);
  write_safetensors(path, {{"w", w}, {"steps", steps}}, {{"format", "test"}}, at::kHalf);

  const SafetensorsFile stored = read_safetensors(path, std::nullopt);
  EXPECT_EQ(stored.tensors.at("w").scalar_type(), at::kHalf);
  EXPECT_TRUE(at::equal(stored.tensors.at("w"), w.to(at::kHalf)));
  EXPECT_TRUE(at::equal(stored.tensors.at("steps"), steps));

  const SafetensorsFile as_float = read_safetensors(path);
  EXPECT_EQ(as_float.tensors.at("w").scalar_type(), at::kFloat);
  EXPECT_TRUE(at::equal(as_float.tensors.at("w"), w.to(at::kHalf).to(at::kFloat)));
  EXPECT_EQ(as_float.tensors.at("steps").scalar_type(), at::kLong);  // integers keep theirs

  write_safetensors(path, {{"w", w}}, {}, at::kBFloat16);
  const SafetensorsFile bf = read_safetensors(path, at::kDouble);
  EXPECT_TRUE(at::equal(bf.tensors.at("w"), w.to(at::kBFloat16).to(at::kDouble)));
  fs::remove_all(dir);
}

// read_weights hands out views of a copy-on-write mapping: they outlive the reader and the
// file's name, and writing to them never reaches the file.
TEST(Safetensors, ReadWeightsViewsOutliveTheReaderAndNeverWriteTheFile) {
  const fs::path dir = fresh_dir("omnipoint_safetensors_views");
  const std::string path = (dir / "w.safetensors").string();
  const at::Tensor w = at::randn({64, 48});
  const at::Tensor steps = at::arange(7, at::kLong);
  write_safetensors(path, {{"w", w}, {"steps", steps}}, {{"format", "test"}});

  at::Tensor view = omnipoint::io::read_weights(path).tensors.at("w");
  ASSERT_TRUE(at::equal(view, w));
  view.add_(1);
  const omnipoint::io::WeightsFile again = omnipoint::io::read_weights(path);
  EXPECT_TRUE(at::equal(again.tensors.at("w"), w));
  EXPECT_TRUE(at::equal(again.tensors.at("steps"), steps));
  EXPECT_EQ(again.metadata.at("format"), "test");

  fs::remove_all(dir);
  EXPECT_TRUE(at::equal(view, w + 1));
  EXPECT_TRUE(at::equal(again.tensors.at("w"), w));
}

TEST(Safetensors, MalformedFilesAreRejected) {
  const std::string ok_entry = R"("a":{"dtype":"F32","shape":[2],"data_offsets":[0,8]})";
  const std::string eight(8, '\0');
  expect_parse_error(std::string("\x05\x00", 2), "shorter than the 8-byte header length");
  expect_parse_error(std::string("\x00\x00\x00\x40\x00\x00\x00\x00", 8) + "{}",
                     "exceeds the 100 MiB cap");
  expect_parse_error(make_file("{}").substr(0, 9), "runs past the end of the file");
  expect_parse_error(make_file("{\"a\":"), "header is not valid JSON");
  expect_parse_error(make_file("[1,2]"), "header is not a JSON object");
  expect_parse_error(make_file("{" + ok_entry + "," + ok_entry + "}", eight),
                     "duplicate key 'a' in the header");
  expect_parse_error(
      make_file(R"({"a":{"dtype":"F32","dtype":"F16","shape":[2],"data_offsets":[0,8]}})", eight),
      "duplicate key 'dtype' in the header");
  expect_parse_error(make_file(R"({"__metadata__":{"f":"a","f":"b"}})"),
                     "duplicate key 'f' in the header");
  expect_parse_error(make_file(R"({"a":{"shape":[2],"data_offsets":[0,8]}})", eight),
                     "tensor 'a': missing string field 'dtype'");
  expect_parse_error(make_file(R"({"a":{"dtype":"F32","data_offsets":[0,8]}})", eight),
                     "missing array field 'shape'");
  expect_parse_error(make_file(R"({"a":{"dtype":"F32","shape":[2]}})", eight),
                     "missing field 'data_offsets'");
  expect_parse_error(make_file(R"({"a":{"dtype":"F32","shape":[-2],"data_offsets":[0,8]}})", eight),
                     "'shape' must hold non-negative integers");
  expect_parse_error(
      make_file(R"({"a":{"dtype":"F32","shape":[2.0],"data_offsets":[0,8]}})", eight),
      "'shape' must hold non-negative integers");
  expect_parse_error(
      make_file(R"({"a":{"dtype":"F32","shape":[2],"data_offsets":[0,"8"]}})", eight),
      "'data_offsets' must be two non-negative integers");
  expect_parse_error(make_file(R"({"a":{"dtype":"F32","shape":[2],"data_offsets":[8,0]}})", eight),
                     "end before they begin");
  expect_parse_error(
      make_file(R"({"a":{"dtype":"F32","shape":[2],"data_offsets":[0,8],"x":1}})", eight),
      "unexpected field 'x'");
  expect_parse_error(make_file(R"({"a":{"dtype":"F17","shape":[2],"data_offsets":[0,8]}})", eight),
                     "unsupported dtype 'F17'");
  expect_parse_error(make_file(R"({"a":{"dtype":"U16","shape":[4],"data_offsets":[0,8]}})", eight),
                     "unsupported dtype 'U16'");
  expect_parse_error(make_file(R"({"a":{"dtype":"F32","shape":[3],"data_offsets":[0,8]}})", eight),
                     "span 8 bytes but dtype F32 and shape [3] need 12");
  expect_parse_error(
      make_file(R"({"a":{"dtype":"F32","shape":[4294967296,4294967296],"data_offsets":[0,8]}})",
                eight),
      "is too large");
  expect_parse_error(make_file(R"({"a":{"dtype":"F32","shape":[2],"data_offsets":[8,16]}})", eight),
                     "past the end of the data section (8 bytes)");
  expect_parse_error(
      make_file("{" + ok_entry + R"(,"b":{"dtype":"F32","shape":[1],"data_offsets":[4,8]}})",
                eight),
      "tensors 'a' and 'b' overlap");
  expect_parse_error(make_file(R"({"a":{"dtype":"F32","shape":[1],"data_offsets":[4,8]}})", eight),
                     "bytes [0, 4) of the data section belong to no tensor");
  expect_parse_error(make_file("{" + ok_entry + "}", eight + "xyz"),
                     "the last 3 bytes of the data section belong to no tensor");
  expect_parse_error(make_file(R"({"__metadata__":{"format":1}})"),
                     "'__metadata__' entry 'format' is not a string");
  expect_parse_error(make_file(R"({"__metadata__":"moge2"})"),
                     "'__metadata__' is not a JSON object");
  expect_parse_error(make_file("{\"a\xff\":1}"), "header is not valid JSON");
  expect_parse_error(make_file(R"({"a":{"dtype":"BOOL","shape":[2],"data_offsets":[0,2]}})",
                               std::string("\x01\x07", 2)),
                     "BOOL data holds a byte other than 0 or 1");
}

TEST(Safetensors, EmptyAndZeroSizedTensorsAreValid) {
  EXPECT_TRUE(parse_safetensors(make_file("{}").data(), 10, "x").tensors.empty());
  const std::string bytes = make_file(R"({"z":{"dtype":"F32","shape":[0,3],"data_offsets":[0,0]},)"
                                      R"("a":{"dtype":"F32","shape":[1],"data_offsets":[0,4]}})",
                                      std::string(4, '\0'));
  const SafetensorsFile file = parse_safetensors(bytes.data(), bytes.size(), "x");
  EXPECT_EQ(file.tensors.at("z").sizes(), (at::IntArrayRef{0, 3}));
}

TEST(Safetensors, MissingFileNamesThePath) {
  try {
    read_safetensors("/nonexistent/model.safetensors");
    FAIL();
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("/nonexistent/model.safetensors"), std::string::npos);
  }
}

// Byte-compatibility with the Python `safetensors` package (vectors from its own tests).
TEST(Safetensors, BytesMatchTheReferenceWriter) {
  const at::Tensor t = at::arange(6, at::kFloat).reshape({1, 2, 3});
  const std::string header = R"({"attn.0":{"dtype":"F32","shape":[1,2,3],"data_offsets":[0,24]}})";
  ASSERT_EQ(header.size() % 8, 0u);
  EXPECT_EQ(encode_safetensors({{"attn.0", t}}),
            make_file(header, std::string(static_cast<const char*>(t.data_ptr()), 24)));
  EXPECT_EQ(encode_safetensors({}, {{"framework", "pt"}}),
            make_file(R"({"__metadata__":{"framework":"pt"}}     )"));
  EXPECT_EQ(encode_safetensors({}), make_file("{}      "));
  // Mixed dtypes: widest alignment first, then by name.
  const std::string mixed = encode_safetensors({{"a", at::zeros({1}, at::kHalf)},
                                                {"b", at::zeros({1}, at::kLong)},
                                                {"c", at::zeros({1}, at::kFloat)}});
  const std::string mixed_header = mixed.substr(8, mixed.size() - 8 - 14);
  EXPECT_LT(mixed_header.find("\"b\""), mixed_header.find("\"c\""));
  EXPECT_LT(mixed_header.find("\"c\""), mixed_header.find("\"a\""));
  EXPECT_NE(mixed_header.find(R"("b":{"dtype":"I64","shape":[1],"data_offsets":[0,8]})"),
            std::string::npos);
}

TEST(Safetensors, WriterRejectsBadInput) {
  EXPECT_THROW(encode_safetensors({{"c", at::zeros({2}, at::kComplexFloat)}}),
               std::invalid_argument);
  EXPECT_THROW(encode_safetensors({{"u", at::Tensor()}}), std::invalid_argument);
  EXPECT_THROW(encode_safetensors({{"bad\xff", at::zeros({2})}}), std::invalid_argument);
  EXPECT_THROW(encode_safetensors({{"w", at::zeros({2})}}, {}, at::kInt), std::invalid_argument);
  EXPECT_THROW(read_safetensors(kFixture, at::kLong), std::invalid_argument);
}

TEST(Safetensors, NonContiguousInputIsWrittenInLogicalOrder) {
  const at::Tensor t = at::arange(12, at::kFloat).reshape({3, 4}).t();
  const std::string bytes = encode_safetensors({{"t", t}});
  const SafetensorsFile back = parse_safetensors(bytes.data(), bytes.size(), "t");
  EXPECT_TRUE(at::equal(back.tensors.at("t"), t));
}

// nlohmann::json parses and frees iteratively, so a hostile header cannot overflow the stack.
TEST(Safetensors, DeeplyNestedHeaderIsRejected) {
  const std::size_t depth = 1000000;
  const std::string header = "{\"a\":" + std::string(depth, '[') + std::string(depth, ']') + "}";
  expect_parse_error(make_file(header), "tensor 'a': entry is not a JSON object");
}
