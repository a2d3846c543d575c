#pragma once
// A stand-in for the Hugging Face hub on 127.0.0.1 (cpp-httplib, in this process), with the
// hub's URL layout and headers (io/hub.h):
//   GET /api/models/OWNER/REPO[/revision/REV]   {"id", "sha", "siblings": [{"rfilename"}, ...]}
//   HEAD|GET /OWNER/REPO/resolve/REV/FILE       LFS files: 302 to the CDN with X-Linked-Etag
//                                               (the SHA-256), X-Linked-Size, X-Repo-Commit;
//                                               small files: 200, ETag (Git's blob SHA-1),
//                                               X-Repo-Commit, the content
// and its CDN, a second server on another port: GET /lfs/SHA256, the content. Both serve byte
// ranges. Faults on demand: a transfer whose connection closes after a given byte, a gated
// repository (401 without its token, 403 with another), an ETag that is not the content's
// checksum. Every request is logged.
#include <httplib.h>
#include <nlohmann/json.hpp>

#include <cstdint>
#include <map>
#include <memory>
#include <mutex>
#include <set>
#include <string>
#include <thread>
#include <vector>

#include "omnipoint/io/digest.h"

namespace omnipoint::test {

using io::Sha1;
using io::Sha256;

class HubServer {
 public:
  HubServer() {
    hub_.Get(R"(/api/models/([^/]+)/([^/]+)(/revision/([^/]+))?)",
             [this](const httplib::Request& req, httplib::Response& res) { model_info(req, res); });
    hub_.Get(R"(/([^/]+)/([^/]+)/resolve/([^/]+)/(.+))",
             [this](const httplib::Request& req, httplib::Response& res) { resolve(req, res); });
    cdn_.Get(R"(/lfs/([0-9a-f]+))",
             [this](const httplib::Request& req, httplib::Response& res) { lfs(req, res); });
    hub_port_ = start(hub_, hub_thread_);
    cdn_port_ = start(cdn_, cdn_thread_);
  }
  ~HubServer() {
    hub_.stop();
    cdn_.stop();
    hub_thread_.join();
    cdn_thread_.join();
  }
  HubServer(const HubServer&) = delete;
  HubServer& operator=(const HubServer&) = delete;

  std::string endpoint() const { return "http://127.0.0.1:" + std::to_string(hub_port_); }

  // A file of `repo` at `revision` (whose commit is the SHA-1 of "REPO@REVISION").
  void add(const std::string& repo, const std::string& file, const std::string& content,
           bool lfs = true, const std::string& revision = "main") {
    std::lock_guard<std::mutex> lock(mutex_);
    Revision& r = repos_[repo][revision];
    r.commit = digest(repo + "@" + revision);
    auto shared = std::make_shared<const std::string>(content);
    r.files[file] = {shared, lfs};
    Sha256 sha;
    sha.update(content);
    blobs_[sha.hex_digest()] = shared;
  }
  static std::string commit_of(const std::string& repo, const std::string& revision = "main") {
    return digest(repo + "@" + revision);
  }
  // Its files answer 401 without "Authorization: Bearer TOKEN", 403 with another token.
  void gate(const std::string& repo, const std::string& token) {
    std::lock_guard<std::mutex> lock(mutex_);
    gates_[repo] = token;
  }
  // The next `count` transfers of file content close the connection at file byte `at`.
  void drop_transfers_at(std::int64_t at, int count = 1) {
    std::lock_guard<std::mutex> lock(mutex_);
    drop_at_ = at;
    drops_left_ = count;
  }
  // The ETag of that file names a checksum its content does not have.
  void corrupt_checksum(const std::string& repo, const std::string& file) {
    std::lock_guard<std::mutex> lock(mutex_);
    corrupt_.insert(repo + "/" + file);
  }
  // "HEAD /path", "GET /path", with " range=bytes=N-" and " auth" where the request had them;
  // CDN requests start with "CDN ".
  std::vector<std::string> requests() const {
    std::lock_guard<std::mutex> lock(mutex_);
    return requests_;
  }
  void clear_requests() {
    std::lock_guard<std::mutex> lock(mutex_);
    requests_.clear();
  }

 private:
  struct File {
    std::shared_ptr<const std::string> content;
    bool lfs = true;
  };
  struct Revision {
    std::string commit;
    std::map<std::string, File> files;
  };

  static std::string digest(const std::string& text) {
    Sha1 sha;
    sha.update(text);
    return sha.hex_digest();
  }
  static int start(httplib::Server& server, std::thread& thread) {
    const int port = server.bind_to_any_port("127.0.0.1");
    thread = std::thread([&server] { server.listen_after_bind(); });
    while (!server.is_running()) std::this_thread::yield();
    return port;
  }

  void log(const std::string& who, const httplib::Request& req) {
    std::string line = who + req.method + " " + req.path;
    if (req.has_header("Range")) line += " range=" + req.get_header_value("Range");
    if (req.has_header("Authorization")) line += " auth";
    std::lock_guard<std::mutex> lock(mutex_);
    requests_.push_back(line);
  }

  const Revision* find(const std::string& repo, const std::string& revision) const {
    const auto r = repos_.find(repo);
    if (r == repos_.end()) return nullptr;
    const auto v = r->second.find(revision);
    return v == r->second.end() ? nullptr : &v->second;
  }

  void model_info(const httplib::Request& req, httplib::Response& res) {
    log("", req);
    const std::string repo = req.matches[1].str() + "/" + req.matches[2].str();
    const std::string revision = req.matches[4].matched ? req.matches[4].str() : "main";
    std::lock_guard<std::mutex> lock(mutex_);
    const Revision* r = find(repo, revision);
    if (r == nullptr) {
      res.status = 404;
      res.set_content(R"({"error":"Repository not found"})", "application/json");
      return;
    }
    nlohmann::json info = {{"id", repo}, {"sha", r->commit}, {"siblings", nlohmann::json::array()}};
    info["siblings"].push_back({{"rfilename", ".gitattributes"}});
    info["siblings"].push_back({{"rfilename", "README.md"}});
    for (const auto& [name, file] : r->files) info["siblings"].push_back({{"rfilename", name}});
    res.set_content(info.dump(), "application/json");
  }

  void resolve(const httplib::Request& req, httplib::Response& res) {
    log("", req);
    const std::string repo = req.matches[1].str() + "/" + req.matches[2].str();
    const std::string revision = req.matches[3].str(), name = req.matches[4].str();
    std::unique_lock<std::mutex> lock(mutex_);
    if (const auto gate = gates_.find(repo); gate != gates_.end()) {
      const std::string auth = req.get_header_value("Authorization");
      if (auth.empty()) {
        res.status = 401;
        res.set_header("X-Error-Code", "GatedRepo");
        return;
      }
      if (auth != "Bearer " + gate->second) {
        res.status = 403;
        return;
      }
    }
    const Revision* r = find(repo, revision);
    const auto file = r == nullptr ? nullptr : [&]() -> const File* {
      const auto f = r->files.find(name);
      return f == r->files.end() ? nullptr : &f->second;
    }();
    if (file == nullptr) {
      res.status = 404;
      res.set_header("X-Error-Code", "EntryNotFound");
      return;
    }
    res.set_header("X-Repo-Commit", r->commit);
    const bool corrupt = corrupt_.count(repo + "/" + name) > 0;
    const std::string content = *file->content + (corrupt ? "!" : "");
    if (file->lfs) {
      Sha256 sha;
      sha.update(*file->content);
      Sha256 claimed;
      claimed.update(content);
      res.status = 302;
      res.set_header("Location",
                     "http://127.0.0.1:" + std::to_string(cdn_port_) + "/lfs/" + sha.hex_digest());
      res.set_header("X-Linked-Etag", "\"" + claimed.hex_digest() + "\"");
      res.set_header("X-Linked-Size", std::to_string(file->content->size()));
      res.set_header("ETag", "\"" + digest("pointer " + name) + "\"");
      return;
    }
    // Git's blob SHA-1: of "blob SIZE\0" and the content.
    Sha1 git;
    git.update("blob " + std::to_string(content.size()) + std::string(1, '\0') + content);
    res.set_header("ETag", "\"" + git.hex_digest() + "\"");
    serve(res, file->content, lock);
  }

  void lfs(const httplib::Request& req, httplib::Response& res) {
    log("CDN ", req);
    std::unique_lock<std::mutex> lock(mutex_);
    const auto blob = blobs_.find(req.matches[1].str());
    if (blob == blobs_.end()) {
      res.status = 404;
      return;
    }
    serve(res, blob->second, lock);
  }

  // The content (httplib answers a Range request with its part), closing the connection at
  // the drop fault's byte while it lasts.
  void serve(httplib::Response& res, const std::shared_ptr<const std::string>& content,
             std::unique_lock<std::mutex>& lock) {
    std::int64_t drop = -1;
    if (drops_left_ > 0) {
      --drops_left_;
      drop = drop_at_;
    }
    lock.unlock();
    res.set_content_provider(
        content->size(), "application/octet-stream",
        [content, drop](size_t offset, size_t length, httplib::DataSink& sink) {
          size_t end = offset + length;
          if (drop >= 0 && end > static_cast<size_t>(drop)) {
            if (offset < static_cast<size_t>(drop))
              sink.write(content->data() + offset, static_cast<size_t>(drop) - offset);
            return false;  // the connection closes mid-file
          }
          sink.write(content->data() + offset, end - offset);
          return true;
        });
  }

  httplib::Server hub_, cdn_;
  std::thread hub_thread_, cdn_thread_;
  int hub_port_ = 0, cdn_port_ = 0;
  mutable std::mutex mutex_;
  std::map<std::string, std::map<std::string, Revision>> repos_;     // repo -> revision -> files
  std::map<std::string, std::shared_ptr<const std::string>> blobs_;  // by SHA-256
  std::map<std::string, std::string> gates_;
  std::set<std::string> corrupt_;
  std::int64_t drop_at_ = -1;
  int drops_left_ = 0;
  std::vector<std::string> requests_;
};

}  // namespace omnipoint::test
