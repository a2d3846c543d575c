#include <ATen/ATen.h>
#include <gtest/gtest.h>

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <string>

#include "omnipoint/io/npy.h"

namespace fs = std::filesystem;
using omnipoint::io::encode_npy;
using omnipoint::io::parse_npy;
using omnipoint::io::read_npy;
using omnipoint::io::write_npy;

namespace {

std::string header_bytes(const std::string& dict) {
  std::string h = dict;
  const std::size_t unpadded = 10 + h.size() + 1;
  h.append((64 - unpadded % 64) % 64, ' ');
  h.push_back('\n');
  std::string out("\x93NUMPY\x01\x00", 8);
  out.push_back(static_cast<char>(h.size() & 0xff));
  out.push_back(static_cast<char>(h.size() >> 8));
  return out + h;
}

void expect_parse_error(const std::string& bytes, const std::string& fragment) {
  try {
    parse_npy(bytes.data(), bytes.size(), "case.npy");
    FAIL() << "expected an error containing '" << fragment << "'";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find(fragment), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("case.npy"), std::string::npos) << e.what();
  }
}

}  // namespace

TEST(Npy, RoundTripEveryDtype) {
  const at::ScalarType types[] = {at::kFloat, at::kDouble, at::kByte,
                                  at::kBool,  at::kInt,    at::kLong};
  for (auto type : types) {
    at::Tensor t = (at::rand({3, 4, 5}, at::kDouble) * 100).to(type);
    if (type == at::kBool) t = at::rand({3, 4, 5}) > 0.5;
    const std::string bytes = encode_npy(t);
    EXPECT_EQ((bytes.size() - t.numel() * t.element_size()) % 64, 0u);
    const at::Tensor back = parse_npy(bytes.data(), bytes.size());
    EXPECT_EQ(back.scalar_type(), type);
    EXPECT_EQ(back.sizes(), t.sizes());
    EXPECT_TRUE(at::equal(back, t));
  }
}

TEST(Npy, RoundTripScalarAndEmptyAndOneDim) {
  for (const at::Tensor& t :
       {at::scalar_tensor(2.5, at::kFloat), at::zeros({0, 3}), at::arange(7, at::kFloat)}) {
    const std::string bytes = encode_npy(t);
    const at::Tensor back = parse_npy(bytes.data(), bytes.size());
    EXPECT_EQ(back.sizes(), t.sizes());
    EXPECT_TRUE(at::equal(back, t));
  }
}

TEST(Npy, NonContiguousInputIsWrittenInLogicalOrder) {
  const at::Tensor t = at::arange(12, at::kFloat).reshape({3, 4}).t();
  const std::string bytes = encode_npy(t);
  EXPECT_TRUE(at::equal(parse_npy(bytes.data(), bytes.size()), t.contiguous()));
}

TEST(Npy, ReadsNumpyWrittenFixture) {
  const std::string path = std::string(OMNIPOINT_FIXTURE_DIR) + "/moge2_forward_a/input.npy";
  const at::Tensor t = read_npy(path);
  EXPECT_EQ(t.scalar_type(), at::kFloat);
  ASSERT_EQ(t.dim(), 4);
  EXPECT_EQ(t.size(1), 3);
  EXPECT_GE(t.min().item<float>(), 0.0f);
  EXPECT_LE(t.max().item<float>(), 1.0f);
  const at::Tensor mask =
      read_npy(std::string(OMNIPOINT_FIXTURE_DIR) + "/moge2_forward_a/expected_infer_mask.npy");
  EXPECT_EQ(mask.scalar_type(), at::kByte);
}

TEST(Npy, WritesFileAtomically) {
  const fs::path dir = fs::temp_directory_path() / "omnipoint_npy_test";
  fs::create_directories(dir);
  const std::string path = (dir / "a.npy").string();
  const at::Tensor t = at::rand({2, 3});
  write_npy(path, t);
  EXPECT_TRUE(at::equal(read_npy(path), t));
  EXPECT_THROW(write_npy((dir / "missing" / "b.npy").string(), t), std::runtime_error);
  EXPECT_THROW(write_npy(path, at::zeros({2}, at::kShort)), std::invalid_argument);
  EXPECT_TRUE(at::equal(read_npy(path), t)) << "a failed write must not touch the old file";
  std::size_t entries = 0;
  for (auto& e : fs::directory_iterator(dir)) {
    (void)e;
    ++entries;
  }
  EXPECT_EQ(entries, 1u) << "no temporary files left behind";
  fs::remove_all(dir);
}

TEST(Npy, RejectsMalformedFiles) {
  const std::string good_dict = "{'descr': '<f4', 'fortran_order': False, 'shape': (2,), }";
  const std::string payload(8, '\0');
  ASSERT_NO_THROW(parse_npy((header_bytes(good_dict) + payload).data(),
                            header_bytes(good_dict).size() + payload.size()));

  expect_parse_error("not an npy file at all", "magic");
  expect_parse_error(std::string("\x93NUMPY", 6), "magic");
  expect_parse_error(header_bytes(good_dict).substr(0, 30), "truncated");
  expect_parse_error(header_bytes(good_dict) + payload.substr(0, 7), "bytes");
  expect_parse_error(header_bytes(good_dict) + payload + "x", "bytes");
  expect_parse_error(
      header_bytes("{'descr': '<f4', 'fortran_order': True, 'shape': (2,), }") + payload,
      "Fortran");
  expect_parse_error(
      header_bytes("{'descr': '>f4', 'fortran_order': False, 'shape': (2,), }") + payload, "dtype");
  expect_parse_error(
      header_bytes("{'descr': '<c8', 'fortran_order': False, 'shape': (1,), }") + payload, "dtype");
  expect_parse_error(header_bytes("{'descr': '<f4', 'shape': (2,), }") + payload, "lacks");
  expect_parse_error(
      header_bytes("{'descr': '<f4', 'fortran_order': False, 'shape': (2,-1), }") + payload,
      "shape");
  expect_parse_error(
      header_bytes("{'descr': '<f4', 'fortran_order': False, 'shape': (2,), 'x': 1}") + payload,
      "unexpected header key");
  expect_parse_error(
      header_bytes("{'descr': '<f4', 'fortran_order': False, 'shape': (99999999999999,), }"),
      "too large");
  expect_parse_error(
      header_bytes("{'descr': '|b1', 'fortran_order': False, 'shape': (2,), }") + "\x01\x02",
      "bool");
  std::string version9 = header_bytes(good_dict) + payload;
  version9[6] = 9;
  expect_parse_error(version9, "version");
}
