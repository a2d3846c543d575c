// The hub client (io/hub.h) against a stand-in hub on 127.0.0.1 (support/hub_server.h) serving a
// real checkpoint under the hub's URL layout: the redirect to the CDN, the model API's file
// list, the cache's reuse, a dropped connection resumed with a Range request (in the same
// fetch, and in the next one), 401/403/404, a wrong checksum, offline and unreachable. After
// every fault the cache holds no file under a final name.
#include <gtest/gtest.h>

#include <algorithm>
#include <cstdlib>
#include <filesystem>
#include <functional>
#include <string>
#include <thread>
#include <vector>

#include "omnipoint/io/atomic_file.h"
#include "omnipoint/io/hub.h"
#include "support/expect_error.h"
#include "support/hub_server.h"
#include "support/scratch_dir.h"

namespace omnipoint::io::hub {
namespace {

namespace fs = std::filesystem;

const std::string kRepo = "Ruicheng/moge-2-vitl-normal";

// One line that contains `part`.
template <typename E>
void expect_error(const std::function<void()>& action, const std::string& part) {
  test::expect_error<E>(action, std::vector<std::string>{part});
}

std::string checkpoint() {
  static const std::string bytes =
      read_file(std::string(OMNIPOINT_FIXTURE_DIR) + "/moge2_forward_a/model.safetensors");
  return bytes;
}

// What a download reports, as lines.
struct Recorder : DownloadObserver {
  std::vector<std::string> events;
  std::int64_t last_present = 0;
  void started(const std::string& name, std::int64_t bytes, std::int64_t resumed_at) override {
    events.push_back("started " + name + " " + std::to_string(bytes) + " " +
                     std::to_string(resumed_at));
  }
  void progress(std::int64_t present, std::int64_t) override { last_present = present; }
  void finished() override { events.emplace_back("finished"); }
  void note(const std::string& text) override { events.push_back("note " + text); }
};

class HubTest : public ::testing::Test {
 protected:
  void SetUp() override {
    if (!http_available()) GTEST_SKIP() << "built without libcurl (OMNIPOINT_WITH_HUB=OFF)";
    ::setenv("no_proxy", "127.0.0.1", 1);  // the stand-in is local whatever proxy is set
    dir_ = test::fresh_process_dir(
        "omnipoint_hub_" +
        std::string(::testing::UnitTest::GetInstance()->current_test_info()->name()));
    settings_.endpoint = server_.endpoint();
    settings_.cache = dir_ / "cache";
    settings_.http.connect_timeout_s = 5;
    settings_.http.stall_timeout_s = 10;
    server_.add(kRepo, "model.safetensors", checkpoint());
  }
  void TearDown() override { fs::remove_all(dir_); }

  // Every file below the cache, relative to it, sorted.
  std::vector<std::string> cache_files() const {
    std::vector<std::string> files;
    if (!fs::exists(settings_.cache)) return files;
    for (const auto& entry : fs::recursive_directory_iterator(settings_.cache))
      if (!entry.is_directory()) files.push_back(entry.path().lexically_relative(settings_.cache));
    std::sort(files.begin(), files.end());
    return files;
  }
  // The cache holds no finished file: no blob, no snapshot link, no ref.
  void expect_nothing_landed() const {
    for (const std::string& file : cache_files())
      EXPECT_NE(file.find(".incomplete"), std::string::npos) << "landed: " << file;
  }
  std::string repo_folder() const {
    return (settings_.cache / "hub" / "models--Ruicheng--moge-2-vitl-normal").string();
  }
  std::string sha256() const {
    Sha256 hash;
    hash.update(checkpoint());
    return hash.hex_digest();
  }

  test::HubServer server_;
  Settings settings_;
  fs::path dir_;
};

TEST(ModelReferences, ParseEveryForm) {
  ModelReference r = parse_model_reference("hf:Ruicheng/moge-2-vitl-normal");
  EXPECT_EQ(r.repo, "Ruicheng/moge-2-vitl-normal");
  EXPECT_EQ(r.file, "");
  EXPECT_EQ(r.revision, "main");
  r = parse_model_reference("hf:owner/repo/sub/dir/model.pt@v1.0");
  EXPECT_EQ(r.repo, "owner/repo");
  EXPECT_EQ(r.file, "sub/dir/model.pt");
  EXPECT_EQ(r.revision, "v1.0");
  EXPECT_EQ(r.text(), "hf:owner/repo/sub/dir/model.pt@v1.0");
  // Short names, with or without hf:, with a file or a revision.
  EXPECT_EQ(parse_model_reference("moge-2-vits-normal").repo, "Ruicheng/moge-2-vits-normal");
  EXPECT_EQ(parse_model_reference("moge-2-vitb-normal").repo, "Ruicheng/moge-2-vitb-normal");
  EXPECT_EQ(parse_model_reference("hf:moge-2-vitl").repo, "Ruicheng/moge-2-vitl");
  r = parse_model_reference("moge-2-vitl-normal/model.pt@abc");
  EXPECT_EQ(r.repo, "Ruicheng/moge-2-vitl-normal");
  EXPECT_EQ(r.file, "model.pt");
  EXPECT_EQ(r.revision, "abc");
}

TEST(ModelReferences, MalformedOnesAreOneLineEach) {
  expect_error<std::invalid_argument>([] { parse_model_reference("hf:moge-3"); },
                                      "is no short name and not OWNER/REPO");
  expect_error<std::invalid_argument>([] { parse_model_reference("hf:a/../b"); },
                                      "expected hf:OWNER/REPO");
  expect_error<std::invalid_argument>([] { parse_model_reference("hf:a/b/x/../y"); },
                                      "is not a path inside the repository");
  expect_error<std::invalid_argument>([] { parse_model_reference("hf:a/b@"); },
                                      "is not a branch, tag or commit name");
  expect_error<std::invalid_argument>([] { parse_model_reference("hf:a/b@x y"); },
                                      "is not a branch, tag or commit name");
}

TEST(ModelReferences, AFileOfAShortNamesNameIsAFile) {
  EXPECT_TRUE(is_model_reference("hf:a/b"));
  EXPECT_TRUE(is_model_reference("moge-2-vitl-normal"));
  EXPECT_FALSE(is_model_reference("model.safetensors"));
  EXPECT_FALSE(is_model_reference("models/moge-2-vitl-normal.pt"));
  const fs::path dir = test::fresh_process_dir("omnipoint_hub_names");
  const fs::path cwd = fs::current_path();
  fs::current_path(dir);
  write_file_atomically("moge-2-vitl", [](std::ostream& out) { out << "weights"; });
  EXPECT_FALSE(is_model_reference("moge-2-vitl"));
  fs::current_path(cwd);
  fs::remove_all(dir);
}

TEST(ModelReferences, CheckpointFilesByExtension) {
  for (const char* name : {"model.pt", "a/b.pth", "m.safetensors"})
    EXPECT_TRUE(is_checkpoint_file(name)) << name;
  for (const char* name : {"README.md", ".gitattributes", "config.json", "model.onnx"})
    EXPECT_FALSE(is_checkpoint_file(name)) << name;
}

TEST(ModelReferences, TheModelApiListsTheCheckpointFilesInsideTheRepository) {
  const std::string info =
      R"({"id": "o/r", "siblings": [{"rfilename": "README.md"}, {"rfilename": "b/model.pt"},)"
      R"( {"rfilename": "a.safetensors"}]})";
  EXPECT_EQ(checkpoint_files(info, "api"),
            (std::vector<std::string>{"a.safetensors", "b/model.pt"}));
  EXPECT_TRUE(checkpoint_files(R"({"siblings": []})", "api").empty());
  // A name that would land outside the cache is refused with the name.
  for (const std::string bad : {"../../evil.pt", "/etc/model.pt", "a/../../b.pt", "a//b.pt"}) {
    try {
      checkpoint_files(R"({"siblings": [{"rfilename": ")" + bad + R"("}]})", "api");
      ADD_FAILURE() << bad << " accepted";
    } catch (const std::runtime_error& e) {
      EXPECT_EQ(std::string(e.what()),
                "api lists the file \"" + bad + "\", which is no path inside the repository");
    }
  }
  // No model description: one line, never a JSON library's exception.
  for (const std::string bad :
       {"", "[]", "{", R"({"siblings": 3})", R"({"siblings": [{"name": "a.pt"}]})",
        R"({"siblings": [{"rfilename": 7}]})"}) {
    try {
      checkpoint_files(bad, "api");
      ADD_FAILURE() << bad << " accepted";
    } catch (const std::runtime_error& e) {
      EXPECT_EQ(std::string(e.what()).rfind("api is not a model description", 0), 0u) << e.what();
    }
  }
}

TEST_F(HubTest, AnLfsFileComesThroughTheRedirectIntoTheCache) {
  Recorder recorder;
  const CachedModel model = fetch_model(parse_model_reference("hf:" + kRepo), settings_, &recorder);
  EXPECT_TRUE(model.downloaded);
  EXPECT_EQ(model.reference.file, "model.safetensors");  // the model API's one checkpoint
  EXPECT_EQ(model.commit, test::HubServer::commit_of(kRepo));
  EXPECT_EQ(read_file(model.path.string()), checkpoint());
  EXPECT_EQ(model.bytes, static_cast<std::int64_t>(checkpoint().size()));
  EXPECT_EQ(model.path, fs::path(repo_folder()) / "snapshots" / model.commit / "model.safetensors");
  EXPECT_TRUE(fs::is_symlink(model.path));
  EXPECT_EQ(read_file(repo_folder() + "/refs/main"), model.commit);
  EXPECT_TRUE(fs::is_regular_file(repo_folder() + "/blobs/" + sha256()));
  ASSERT_EQ(recorder.events.size(), 2u);
  EXPECT_EQ(recorder.events[0], "started hf:" + kRepo + "/model.safetensors " +
                                    std::to_string(checkpoint().size()) + " 0");
  EXPECT_EQ(recorder.last_present, static_cast<std::int64_t>(checkpoint().size()));
  const std::vector<std::string> requests = server_.requests();
  const std::vector<std::string> expected = {
      "GET /api/models/" + kRepo, "HEAD /" + kRepo + "/resolve/main/model.safetensors",
      "GET /" + kRepo + "/resolve/main/model.safetensors", "CDN GET /lfs/" + sha256()};
  EXPECT_EQ(requests, expected);

  // Again: the HEAD answer names the cached blob, so nothing is transferred.
  server_.clear_requests();
  const CachedModel again = fetch_model(parse_model_reference("moge-2-vitl-normal"), settings_);
  EXPECT_FALSE(again.downloaded);
  EXPECT_EQ(again.path, model.path);
  const std::vector<std::string> head_only = {"GET /api/models/" + kRepo,
                                              "HEAD /" + kRepo + "/resolve/main/model.safetensors"};
  EXPECT_EQ(server_.requests(), head_only);
  ASSERT_EQ(cached_models(settings_.cache).size(), 1u);
  EXPECT_EQ(cached_models(settings_.cache)[0].reference.text(),
            "hf:" + kRepo + "/model.safetensors");
}

TEST_F(HubTest, ADroppedConnectionIsResumedWithARangeRequest) {
  const std::int64_t half = static_cast<std::int64_t>(checkpoint().size() / 2);
  server_.drop_transfers_at(half);
  Recorder recorder;
  const CachedModel model = fetch_model(parse_model_reference("hf:" + kRepo + "/model.safetensors"),
                                        settings_, &recorder);
  EXPECT_EQ(read_file(model.path.string()), checkpoint());
  const std::vector<std::string> requests = server_.requests();
  ASSERT_EQ(requests.size(), 5u);
  EXPECT_EQ(requests[2], "CDN GET /lfs/" + sha256());
  // The Range header travels with the redirect to the CDN.
  EXPECT_EQ(requests[3], "GET /" + kRepo + "/resolve/main/model.safetensors range=bytes=" +
                             std::to_string(half) + "-");
  EXPECT_EQ(requests[4], "CDN GET /lfs/" + sha256() + " range=bytes=" + std::to_string(half) + "-");
  ASSERT_EQ(recorder.events.size(), 3u);
  EXPECT_EQ(recorder.events[1].rfind("note the connection dropped at " + std::to_string(half) +
                                         " of " + std::to_string(checkpoint().size()) + " bytes",
                                     0),
            0u)
      << recorder.events[1];
}

TEST_F(HubTest, AnInterruptedDownloadIsResumedByTheNextFetch) {
  const std::int64_t third = static_cast<std::int64_t>(checkpoint().size() / 3);
  server_.drop_transfers_at(third);
  settings_.attempts = 1;
  const ModelReference reference = parse_model_reference("hf:" + kRepo + "/model.safetensors");
  expect_error<std::runtime_error>([&] { fetch_model(reference, settings_); },
                                   "hf:" + kRepo + "/model.safetensors: the download stopped at " +
                                       std::to_string(third) + " of " +
                                       std::to_string(checkpoint().size()) + " bytes");
  // The part that arrived waits for the next run; nothing else is there.
  const std::vector<std::string> partial = {"hub/models--Ruicheng--moge-2-vitl-normal/blobs/" +
                                            sha256() + ".incomplete"};
  EXPECT_EQ(cache_files(), partial);
  EXPECT_EQ(fs::file_size(settings_.cache / partial[0]), static_cast<std::uintmax_t>(third));

  server_.clear_requests();
  Recorder recorder;
  const CachedModel model = fetch_model(reference, settings_, &recorder);
  EXPECT_EQ(read_file(model.path.string()), checkpoint());
  EXPECT_EQ(recorder.events[0], "started " + reference.text() + " " +
                                    std::to_string(checkpoint().size()) + " " +
                                    std::to_string(third));
  const std::vector<std::string> requests = server_.requests();
  ASSERT_EQ(requests.size(), 3u);
  EXPECT_EQ(requests[2],
            "CDN GET /lfs/" + sha256() + " range=bytes=" + std::to_string(third) + "-");
  EXPECT_FALSE(fs::exists(settings_.cache / partial[0]));
}

TEST_F(HubTest, AMissingFileIsNotFoundWithItsUrl) {
  expect_error<std::runtime_error>(
      [&] { fetch_model(parse_model_reference("hf:" + kRepo + "/other.pt"), settings_); },
      "hf:" + kRepo + "/other.pt: not found (HTTP 404): " + server_.endpoint() + "/" + kRepo +
          "/resolve/main/other.pt");
  expect_error<std::runtime_error>(
      [&] { fetch_model(parse_model_reference("hf:nobody/nothing"), settings_); },
      "hf:nobody/nothing: not found (HTTP 404): " + server_.endpoint() +
          "/api/models/nobody/nothing");
  EXPECT_TRUE(cache_files().empty());
}

TEST_F(HubTest, AGatedRepositoryNeedsItsToken) {
  server_.gate(kRepo, "secret");
  const ModelReference reference = parse_model_reference("moge-2-vitl-normal");
  expect_error<std::runtime_error>([&] { fetch_model(reference, settings_); },
                                   "access denied (HTTP 401): a gated or private "
                                   "repository needs a token");
  settings_.token = "wrong";
  expect_error<std::runtime_error>([&] { fetch_model(reference, settings_); },
                                   "access denied (HTTP 403) with the token in HF_TOKEN");
  EXPECT_TRUE(cache_files().empty());
  settings_.token = "secret";
  server_.clear_requests();
  EXPECT_EQ(read_file(fetch_model(reference, settings_).path.string()), checkpoint());
  // The token goes to the hub, never to the CDN (another port).
  for (const std::string& request : server_.requests())
    EXPECT_EQ(request.find(" auth") != std::string::npos, request.rfind("CDN ", 0) != 0) << request;
}

TEST_F(HubTest, AWrongChecksumRemovesTheDownload) {
  server_.corrupt_checksum(kRepo, "model.safetensors");
  expect_error<std::runtime_error>(
      [&] { fetch_model(parse_model_reference("moge-2-vitl-normal"), settings_); },
      "hf:" + kRepo + "/model.safetensors: checksum mismatch: the download has sha256 " + sha256());
  EXPECT_TRUE(cache_files().empty());
}

TEST_F(HubTest, SmallFilesAreCheckedAgainstTheirGitBlobSha1) {
  server_.add("owner/small", "tiny.pt", "not really a checkpoint", /*lfs=*/false);
  const CachedModel model = fetch_model(parse_model_reference("hf:owner/small"), settings_);
  EXPECT_EQ(read_file(model.path.string()), "not really a checkpoint");
  server_.corrupt_checksum("owner/small", "tiny.pt");
  server_.add("owner/small", "tiny.pt", "changed content", /*lfs=*/false);
  expect_error<std::runtime_error>(
      [&] { fetch_model(parse_model_reference("hf:owner/small"), settings_); },
      "checksum mismatch: the download has git blob sha1");
}

TEST_F(HubTest, SeveralCheckpointsMustBeNamed) {
  server_.add(kRepo, "model.pt", "other weights");
  expect_error<std::runtime_error>(
      [&] { fetch_model(parse_model_reference("moge-2-vitl-normal"), settings_); },
      "hf:" + kRepo +
          " has 2 checkpoint files (model.pt, model.safetensors): name one, hf:" + kRepo + "/FILE");
  EXPECT_EQ(read_file(fetch_model(parse_model_reference("moge-2-vitl-normal/model.pt"), settings_)
                          .path.string()),
            "other weights");
}

TEST_F(HubTest, ARevisionHasItsOwnSnapshotAndRef) {
  server_.add(kRepo, "model.safetensors", "version one", true, "v1");
  const CachedModel v1 = fetch_model(parse_model_reference("moge-2-vitl-normal@v1"), settings_);
  EXPECT_EQ(read_file(v1.path.string()), "version one");
  EXPECT_EQ(v1.commit, test::HubServer::commit_of(kRepo, "v1"));
  EXPECT_EQ(read_file(repo_folder() + "/refs/v1"), v1.commit);
  EXPECT_EQ(server_.requests()[0], "GET /api/models/" + kRepo + "/revision/v1");
  const CachedModel main = fetch_model(parse_model_reference("moge-2-vitl-normal"), settings_);
  EXPECT_NE(main.path, v1.path);
  const std::vector<CachedModel> cached = cached_models(settings_.cache);
  ASSERT_EQ(cached.size(), 2u);
  std::vector<std::string> names = {cached[0].reference.text(), cached[1].reference.text()};
  std::sort(names.begin(), names.end());
  EXPECT_EQ(names[0], "hf:" + kRepo + "/model.safetensors");
  EXPECT_EQ(names[1], "hf:" + kRepo + "/model.safetensors@v1");
}

TEST_F(HubTest, OfflineUsesTheCacheOnlyAndMakesNoRequest) {
  settings_.offline = true;
  const ModelReference reference = parse_model_reference("moge-2-vitl-normal");
  expect_error<std::runtime_error>([&] { fetch_model(reference, settings_); },
                                   "hf:" + kRepo + ": HF_HUB_OFFLINE is set and the cache (" +
                                       settings_.cache.string() + ") holds no copy");
  EXPECT_TRUE(server_.requests().empty());
  settings_.offline = false;
  const CachedModel online = fetch_model(reference, settings_);
  server_.clear_requests();
  settings_.offline = true;
  const CachedModel offline = fetch_model(reference, settings_);
  EXPECT_EQ(offline.path, online.path);
  EXPECT_EQ(offline.reference.file, "model.safetensors");
  EXPECT_FALSE(offline.downloaded);
  EXPECT_TRUE(server_.requests().empty());
}

TEST_F(HubTest, AnUnreachableHubFallsBackToTheCachedCopy) {
  const ModelReference reference = parse_model_reference("moge-2-vitl-normal");
  Settings unreachable = settings_;
  unreachable.endpoint = "http://127.0.0.1:9";  // discard: nothing listens
  expect_error<std::runtime_error>([&] { fetch_model(reference, unreachable); },
                                   "hf:" + kRepo + ": cannot reach the hub (");
  EXPECT_TRUE(cache_files().empty());
  const CachedModel online = fetch_model(reference, settings_);
  Recorder recorder;
  const CachedModel cached = fetch_model(reference, unreachable, &recorder);
  EXPECT_EQ(cached.path, online.path);
  ASSERT_EQ(recorder.events.size(), 1u);
  EXPECT_EQ(recorder.events[0].rfind("note cannot reach the hub (", 0), 0u) << recorder.events[0];
}

// Two fetches at once: one downloads under the lock, the other finds the blob after it.
TEST_F(HubTest, ConcurrentFetchesDownloadOnce) {
  std::vector<CachedModel> models(2);
  std::vector<std::thread> threads;
  for (int i = 0; i < 2; ++i)
    threads.emplace_back([&, i] {
      models[i] = fetch_model(parse_model_reference("moge-2-vitl-normal"), settings_);
    });
  for (std::thread& thread : threads) thread.join();
  EXPECT_EQ(models[0].path, models[1].path);
  EXPECT_EQ(read_file(models[0].path.string()), checkpoint());
  int transfers = 0;
  for (const std::string& request : server_.requests())
    transfers += request.rfind("CDN GET", 0) == 0 ? 1 : 0;
  EXPECT_EQ(transfers, 1);
  const std::vector<std::string> landed = {
      "hub/models--Ruicheng--moge-2-vitl-normal/blobs/" + sha256(),
      "hub/models--Ruicheng--moge-2-vitl-normal/refs/main",
      "hub/models--Ruicheng--moge-2-vitl-normal/snapshots/" + models[0].commit +
          "/model.safetensors"};
  EXPECT_EQ(cache_files(), landed);
}

TEST(HubSettings, TheEnvironmentNamesTheEndpointTokenCacheAndOfflineMode) {
  const std::string home = std::getenv("HOME") != nullptr ? std::getenv("HOME") : "";
  ::setenv("HF_ENDPOINT", "http://mirror.example/", 1);
  ::setenv("HF_TOKEN", "t0k", 1);
  ::setenv("HF_HUB_OFFLINE", "yes", 1);
  ::setenv("OMNIPOINT_CACHE", "/some/cache", 1);
  Settings settings = Settings::from_environment();
  EXPECT_EQ(settings.endpoint, "http://mirror.example");
  EXPECT_EQ(settings.token, "t0k");
  EXPECT_TRUE(settings.offline);
  EXPECT_EQ(settings.cache, fs::path("/some/cache"));
  ::unsetenv("HF_ENDPOINT");
  ::unsetenv("HF_TOKEN");
  ::setenv("HF_HUB_OFFLINE", "0", 1);
  ::unsetenv("OMNIPOINT_CACHE");
  ::setenv("XDG_CACHE_HOME", "/xdg", 1);
  settings = Settings::from_environment();
  EXPECT_EQ(settings.endpoint, "https://huggingface.co");
  EXPECT_EQ(settings.token, "");
  EXPECT_FALSE(settings.offline);
  EXPECT_EQ(settings.cache, fs::path("/xdg/omnipoint"));
  ::unsetenv("XDG_CACHE_HOME");
  ::setenv("HOME", "/home/someone", 1);
  EXPECT_EQ(Settings::from_environment().cache, fs::path("/home/someone/.cache/omnipoint"));
  ::unsetenv("HOME");
  EXPECT_THROW(Settings::from_environment(), std::runtime_error);
  ::setenv("HOME", home.c_str(), 1);
  ::unsetenv("HF_HUB_OFFLINE");
}

TEST(HubSizes, ReadLikeAFileManagerSays) {
  EXPECT_EQ(human_bytes(512), "512 B");
  EXPECT_EQ(human_bytes(2252172), "2.25 MB");
  EXPECT_EQ(human_bytes(1324000000), "1.32 GB");
  EXPECT_EQ(human_bytes(45600), "45.6 kB");
}

}  // namespace
}  // namespace omnipoint::io::hub
