// The hub client of io/hub.h: references, the cache layout, the HEAD/GET exchange with its
// resume, verification and atomic landing.
#include "omnipoint/io/hub.h"

#include <fcntl.h>
#include <sys/file.h>
#include <sys/stat.h>
#include <unistd.h>

#include <nlohmann/json.hpp>

#include <algorithm>
#include <atomic>
#include <cctype>
#include <cerrno>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <map>
#include <stdexcept>
#include <system_error>

#include "omnipoint/io/atomic_file.h"
#include "omnipoint/io/digest.h"

namespace omnipoint::io::hub {

namespace fs = std::filesystem;

namespace {

const char* const kPrefix = "hf:";

bool is_hex(const std::string& text, std::size_t length) {
  return text.size() == length && std::all_of(text.begin(), text.end(), [](unsigned char c) {
           return std::isdigit(c) || (c >= 'a' && c <= 'f');
         });
}

std::string environment(const char* name) {
  const char* value = std::getenv(name);
  return value != nullptr ? value : "";
}

// The hub's client reads these as true (case-insensitive).
bool truthy(std::string value) {
  std::transform(value.begin(), value.end(), value.begin(),
                 [](unsigned char c) { return static_cast<char>(std::toupper(c)); });
  return value == "1" || value == "ON" || value == "YES" || value == "TRUE";
}

// Percent-encoding of everything but RFC 3986's unreserved characters (and '/' in paths).
std::string url_encode(const std::string& text, bool keep_slash) {
  std::string encoded;
  for (unsigned char c : text) {
    if (std::isalnum(c) || c == '-' || c == '.' || c == '_' || c == '~' ||
        (keep_slash && c == '/')) {
      encoded += static_cast<char>(c);
    } else {
      char escape[4];
      std::snprintf(escape, sizeof escape, "%%%02X", c);
      encoded += escape;
    }
  }
  return encoded;
}

// An OWNER or REPO name: letters, digits, '-', '_', '.', not starting with '.' or '-', no "..".
bool valid_name(const std::string& name) {
  if (name.empty() || name.size() > 96 || name[0] == '.' || name[0] == '-' ||
      name.find("..") != std::string::npos)
    return false;
  return std::all_of(name.begin(), name.end(), [](unsigned char c) {
    return std::isalnum(c) || c == '-' || c == '_' || c == '.';
  });
}

std::string short_name_list() {
  std::string names;
  for (const ShortName& s : short_names()) names += (names.empty() ? "" : ", ") + s.name;
  return names;
}

// A path inside a repository: relative, no empty, "." or ".." component, no trailing '/', no
// backslash.
bool is_repository_path(const std::string& file) {
  if (file.empty() || file.back() == '/' || file.find("//") != std::string::npos ||
      file.find('\\') != std::string::npos)
    return false;
  for (const fs::path& part : fs::path(file))
    if (part.empty() || part == "." || part == ".." || part == "/") return false;
  return true;
}

void check_reference(const ModelReference& reference, const std::string& text) {
  const auto bad = [&](const std::string& why) {
    throw std::invalid_argument("model " + text + ": " + why);
  };
  const auto slash = reference.repo.find('/');
  if (slash == std::string::npos || !valid_name(reference.repo.substr(0, slash)) ||
      !valid_name(reference.repo.substr(slash + 1)))
    bad("expected hf:OWNER/REPO[/FILE][@REVISION] (or a short name: " + short_name_list() + ")");
  if (!reference.file.empty() && !is_repository_path(reference.file))
    bad("the file \"" + reference.file + "\" is not a path inside the repository");
  const std::string& revision = reference.revision;
  if (revision.empty() || revision.find("..") != std::string::npos || revision[0] == '/' ||
      !std::all_of(revision.begin(), revision.end(), [](unsigned char c) {
        return std::isalnum(c) || c == '-' || c == '_' || c == '.' || c == '/';
      }))
    bad("the revision \"" + revision + "\" is not a branch, tag or commit name");
}

const ShortName* find_short_name(const std::string& name) {
  for (const ShortName& s : short_names())
    if (s.name == name) return &s;
  return nullptr;
}

// The part of a reference before any /FILE or @REVISION.
std::string leading_name(const std::string& text) {
  return text.substr(0, text.find_first_of("/@"));
}

// ---- the cache layout ----

fs::path repo_folder(const fs::path& cache, const std::string& repo) {
  std::string name = repo;
  name.replace(name.find('/'), 1, "--");
  return cache / "hub" / ("models--" + name);
}

// A blob's file name: the ETag where it is a safe name (the hub's are hex), else its SHA-256.
std::string blob_name(const std::string& etag) {
  const bool safe = !etag.empty() && etag.size() <= 128 && etag[0] != '.' &&
                    std::all_of(etag.begin(), etag.end(), [](unsigned char c) {
                      return std::isalnum(c) || c == '-' || c == '_' || c == '.';
                    });
  if (safe) return etag;
  Sha256 hash;
  hash.update(etag);
  return hash.hex_digest();
}

std::string ref_name(const std::string& revision) {
  return url_encode(revision, false);
}

std::string ref_revision(const std::string& name) {
  std::string revision;
  for (std::size_t i = 0; i < name.size(); ++i) {
    if (name[i] == '%' && i + 2 < name.size()) {
      revision += static_cast<char>(std::stoi(name.substr(i + 1, 2), nullptr, 16));
      i += 2;
    } else {
      revision += name[i];
    }
  }
  return revision;
}

// The commit a revision stands for in the cache: refs/REVISION, or the revision itself when
// it is a commit with a snapshot.
std::optional<std::string> cached_commit(const fs::path& repo, const std::string& revision) {
  const fs::path ref = repo / "refs" / ref_name(revision);
  std::error_code error;
  if (fs::is_regular_file(ref, error)) {
    std::string commit = read_file(ref.string());
    commit.erase(commit.find_last_not_of(" \n\r\t") + 1);
    if (!commit.empty()) return commit;
  }
  if (fs::is_directory(repo / "snapshots" / revision, error)) return revision;
  return std::nullopt;
}

// The checkpoint files of a snapshot folder (paths relative to it), sorted.
std::vector<std::string> snapshot_checkpoints(const fs::path& snapshot) {
  std::vector<std::string> files;
  std::error_code error;
  for (fs::recursive_directory_iterator it(snapshot, error), end; !error && it != end;
       it.increment(error)) {
    const std::string relative = it->path().lexically_relative(snapshot).generic_string();
    if (it->is_symlink() && fs::is_regular_file(it->path()) && is_checkpoint_file(relative))
      files.push_back(relative);
  }
  std::sort(files.begin(), files.end());
  return files;
}

std::string several(const std::string& name, const std::vector<std::string>& files,
                    const std::string& where) {
  std::string list;
  for (const std::string& file : files) list += (list.empty() ? "" : ", ") + file;
  return name + " " + where + " " + std::to_string(files.size()) + " checkpoint files (" + list +
         "): name one, " + name + "/FILE";
}

// The cached copy of `reference` at its revision, if any.
std::optional<CachedModel> find_cached(const ModelReference& reference, const fs::path& cache) {
  const fs::path repo = repo_folder(cache, reference.repo);
  const std::optional<std::string> commit = cached_commit(repo, reference.revision);
  if (!commit) return std::nullopt;
  const fs::path snapshot = repo / "snapshots" / *commit;
  CachedModel model;
  model.reference = reference;
  model.commit = *commit;
  if (reference.file.empty()) {
    const std::vector<std::string> files = snapshot_checkpoints(snapshot);
    if (files.size() > 1)
      throw std::runtime_error(several(reference.text(), files, "has in the cache"));
    if (files.empty()) return std::nullopt;
    model.reference.file = files.front();
  }
  model.path = snapshot / model.reference.file;
  std::error_code error;
  if (!fs::is_regular_file(model.path, error)) return std::nullopt;  // follows the link
  model.bytes = static_cast<std::int64_t>(fs::file_size(model.path, error));
  return model;
}

// `target` at `link`, replacing what was there, by a rename. The staging name is unique to the
// call: two threads of one process may enter the same model at once.
void place_symlink(const fs::path& target, const fs::path& link) {
  static std::atomic<std::uint64_t> calls{0};
  fs::create_directories(link.parent_path());
  const fs::path staging =
      link.parent_path() / ("." + link.filename().string() + ".link-" + std::to_string(getpid()) +
                            "-" + std::to_string(calls.fetch_add(1)));
  std::error_code error;
  fs::remove(staging, error);
  fs::create_symlink(target, staging);
  fs::rename(staging, link);
}

// The snapshot link of a verified blob, and the revision's ref.
CachedModel enter(const ModelReference& reference, const fs::path& cache, const std::string& commit,
                  const std::string& blob) {
  const fs::path repo = repo_folder(cache, reference.repo);
  const fs::path link = repo / "snapshots" / commit / reference.file;
  // From the link's folder up to the repository folder, then into blobs/.
  fs::path target;
  for (const fs::path& up : fs::relative(repo, link.parent_path())) target /= up;
  place_symlink(target / "blobs" / blob, link);
  if (reference.revision != commit) {
    fs::create_directories(repo / "refs");
    write_file_atomically((repo / "refs" / ref_name(reference.revision)).string(),
                          [&](std::ostream& out) { out << commit; });
  }
  CachedModel model;
  model.reference = reference;
  model.commit = commit;
  model.path = link;
  model.bytes = static_cast<std::int64_t>(fs::file_size(link));
  return model;
}

// ---- requests ----

std::string origin_of(const std::string& url) {
  const auto scheme = url.find("://");
  const auto path = url.find('/', scheme == std::string::npos ? 0 : scheme + 3);
  return path == std::string::npos ? url : url.substr(0, path);
}

std::string header(const HttpResponse& response, const std::string& name) {
  const auto found = response.headers.find(name);
  return found == response.headers.end() ? "" : found->second;
}

// The one line for an answer that is no success.
[[noreturn]] void fail_status(const std::string& name, const HttpResponse& response,
                              const std::string& url, const Settings& settings) {
  const long status = response.status;
  const std::string code = "HTTP " + std::to_string(status);
  if (status == 401 || status == 403) {
    if (settings.token.empty())
      throw std::runtime_error(name + ": access denied (" + code +
                               "): a gated or private repository needs a token: accept its terms "
                               "on the hub and set HF_TOKEN to an access token of that account");
    throw std::runtime_error(name + ": access denied (" + code +
                             ") with the token in HF_TOKEN: the account has no access to this "
                             "repository (gated: accept its terms on the hub) or the token is "
                             "invalid");
  }
  if (status == 404)
    throw std::runtime_error(name + ": not found (" + code + "): " + url +
                             " (check the repository, file and revision)");
  throw std::runtime_error(name + ": the hub answered " + code + " for " + url);
}

[[noreturn]] void fail_unreachable(const std::string& name, const HttpUnreachable& e) {
  throw std::runtime_error(name + ": cannot reach the hub (" + std::string(e.what()) +
                           "): no network? (HF_HUB_OFFLINE=1 uses the cache only)");
}

HttpOptions http_options(const Settings& settings) {
  HttpOptions http = settings.http;
  http.bearer_token = settings.token;
  return http;
}

// FILE of a reference without one: the model API's one checkpoint file.
std::string the_checkpoint_file(const ModelReference& reference, const Settings& settings) {
  std::string url = settings.endpoint + "/api/models/" + reference.repo;
  if (reference.revision != "main") url += "/revision/" + url_encode(reference.revision, false);
  const std::string name = reference.text();
  const HttpResponse response = http_get(url, http_options(settings));
  if (response.status != 200) fail_status(name, response, url, settings);
  const std::vector<std::string> files =
      checkpoint_files(response.body, name + ": the model API's answer (" + url + ")");
  if (files.size() > 1) throw std::runtime_error(several(name, files, "has"));
  if (files.empty())
    throw std::runtime_error(name + " has no checkpoint file (.safetensors, .pt, .pth) in " + url);
  return files.front();
}

// What the hub says about a file (its HEAD answer).
struct FileFacts {
  std::string url;     // the resolve URL the GET starts from
  std::string etag;    // normalised: no W/ prefix, no quotes
  std::int64_t bytes;  // -1 when unknown
  std::string commit;  // X-Repo-Commit; "" when absent
};

FileFacts file_facts(const ModelReference& reference, const Settings& settings) {
  FileFacts facts;
  facts.url = settings.endpoint + "/" + reference.repo + "/resolve/" +
              url_encode(reference.revision, false) + "/" + url_encode(reference.file, true);
  const std::string name = reference.text();
  std::string url = facts.url;
  HttpResponse response;
  // Relative redirects stay on the hub (a renamed repository); an absolute one is the CDN's,
  // whose answer is not needed: the first answer carries the facts.
  for (int hop = 0;; ++hop) {
    response = http_head(url, http_options(settings));
    const std::string location = header(response, "location");
    const bool redirect = response.status >= 300 && response.status < 400;
    if (!redirect || location.empty() || location[0] != '/' || hop == 5) break;
    url = origin_of(url) + location;
  }
  if (response.status >= 400 || response.status < 200) fail_status(name, response, url, settings);
  const bool redirect = response.status >= 300;
  std::string etag = header(response, "x-linked-etag");
  if (etag.empty()) etag = header(response, "etag");
  if (etag.rfind("W/", 0) == 0) etag = etag.substr(2);
  etag.erase(std::remove(etag.begin(), etag.end(), '"'), etag.end());
  if (etag.empty())
    throw std::runtime_error(name + ": the hub gave no ETag for " + url +
                             ", so the download could not be verified");
  facts.etag = etag;
  std::string size = header(response, "x-linked-size");
  if (size.empty() && !redirect) size = header(response, "content-length");
  facts.bytes = -1;
  if (!size.empty()) {
    char* end = nullptr;
    const long long value = std::strtoll(size.c_str(), &end, 10);
    if (end != nullptr && *end == '\0' && value >= 0) facts.bytes = value;
  }
  facts.commit = header(response, "x-repo-commit");
  return facts;
}

// ---- the download ----

// An open file with an exclusive flock, closed on destruction.
class LockedFile {
 public:
  // Opens (creating) `path` and waits for its lock; nullopt-like state (fd -1) when `done`
  // turned true meanwhile (another process finished the work).
  explicit LockedFile(const fs::path& path) : path_(path) {
    for (;;) {
      fd_ = ::open(path.c_str(), O_RDWR | O_CREAT | O_CLOEXEC, 0644);
      if (fd_ < 0) fail("cannot open");
      if (::flock(fd_, LOCK_EX) != 0) fail("cannot lock");
      // The holder before us may have renamed or removed the file: lock the file at the path.
      struct stat held, named;
      if (::fstat(fd_, &held) == 0 && ::stat(path.c_str(), &named) == 0 &&
          held.st_ino == named.st_ino && held.st_dev == named.st_dev)
        return;
      ::close(fd_);
    }
  }
  ~LockedFile() {
    if (fd_ >= 0) ::close(fd_);
  }
  LockedFile(const LockedFile&) = delete;
  LockedFile& operator=(const LockedFile&) = delete;

  int fd() const { return fd_; }
  std::int64_t size() const {
    struct stat info;
    if (::fstat(fd_, &info) != 0) fail("cannot read the size of");
    return static_cast<std::int64_t>(info.st_size);
  }
  void truncate() const {
    if (::ftruncate(fd_, 0) != 0) fail("cannot truncate");
  }
  void append(const char* data, std::size_t size) const {
    while (size > 0) {
      const ssize_t written = ::write(fd_, data, size);
      if (written < 0 && errno == EINTR) continue;
      if (written <= 0) fail("cannot write");
      data += written;
      size -= static_cast<std::size_t>(written);
    }
  }
  void sync() const {
    if (::fsync(fd_) != 0) fail("cannot sync");
  }

 private:
  [[noreturn]] void fail(const std::string& what) const {
    throw std::runtime_error(what + " " + path_.string() + ": " + std::strerror(errno));
  }
  fs::path path_;
  int fd_ = -1;
};

// The file's checksum as the ETag states it: a 64-hex ETag is the SHA-256 of an LFS file, a
// 40-hex one Git's blob SHA-1 of a small file. Returns "" when it matches or the ETag is no
// checksum, else the mismatch's description.
std::string checksum_mismatch(const fs::path& file, const std::string& etag) {
  if (is_hex(etag, 64)) {
    const std::string actual = sha256_of_file(file.string());
    return actual == etag ? "" : "sha256 " + actual + ", expected " + etag;
  }
  if (is_hex(etag, 40)) {
    const std::string actual = git_blob_sha1_of_file(file.string());
    return actual == etag ? "" : "git blob sha1 " + actual + ", expected " + etag;
  }
  return "";
}

// Transfers the file into `partial` (resuming what it holds), trying settings.attempts times.
void transfer(const std::string& name, const FileFacts& facts, const LockedFile& partial,
              const Settings& settings, DownloadObserver& observer) {
  std::int64_t present = partial.size();
  if (facts.bytes >= 0 && present > facts.bytes) {  // not this file's start
    partial.truncate();
    present = 0;
  }
  observer.started(name, facts.bytes, present);
  if (facts.bytes >= 0 && present == facts.bytes) return;  // complete, not yet verified
  HttpSink sink;
  std::int64_t offset = 0;
  sink.begin = [&](bool continues) {
    if (!continues && offset > 0) {  // the server sends the whole file after all
      partial.truncate();
      offset = 0;
    }
    ::lseek(partial.fd(), 0, SEEK_END);
  };
  sink.write = [&](const char* data, std::size_t size) {
    partial.append(data, size);
    return true;
  };
  sink.progress = [&](std::int64_t received, std::int64_t) {
    observer.progress(offset + received, facts.bytes);
  };
  for (int attempt = 1;; ++attempt) {
    offset = partial.size();
    const HttpTransfer result = http_download(facts.url, offset, http_options(settings), sink);
    const long status = result.response.status;
    if (status == 416 && facts.bytes >= 0 && partial.size() == facts.bytes) return;
    if (status == 416) {  // the range is past the file: start again
      partial.truncate();
      if (attempt < settings.attempts) continue;
    }
    if (status < 200 || status >= 300) fail_status(name, result.response, facts.url, settings);
    if (result.complete) return;
    const std::string where = std::to_string(partial.size()) + " of " +
                              (facts.bytes >= 0 ? std::to_string(facts.bytes) : "?") + " bytes";
    if (attempt >= std::max(1, settings.attempts))
      throw std::runtime_error(name + ": the download stopped at " + where + " (" + result.error +
                               "); run the command again to resume it");
    observer.note("the connection dropped at " + where + " (" + result.error + "): resuming");
  }
}

// Downloads, verifies and lands blobs/BLOB (a no-op when another process landed it first).
void download_blob(const std::string& name, const FileFacts& facts, const fs::path& blob,
                   const Settings& settings, DownloadObserver& observer) {
  fs::create_directories(blob.parent_path());
  const fs::path partial_path = blob.string() + ".incomplete";
  const LockedFile partial(partial_path);
  if (fs::exists(blob)) {  // landed while we waited for the lock
    fs::remove(partial_path);
    return;
  }
  try {
    transfer(name, facts, partial, settings, observer);
  } catch (...) {
    observer.finished();
    // What arrived stays for the next run to resume; an empty file is no download.
    if (partial.size() == 0) fs::remove(partial_path);
    throw;
  }
  observer.finished();
  const std::int64_t bytes = partial.size();
  if (facts.bytes >= 0 && bytes != facts.bytes) {
    fs::remove(partial_path);
    throw std::runtime_error(name + ": size mismatch: the download has " + std::to_string(bytes) +
                             " bytes, the hub said " + std::to_string(facts.bytes) +
                             " (the download was removed; run the command again)");
  }
  partial.sync();
  const std::string mismatch = checksum_mismatch(partial_path, facts.etag);
  if (!mismatch.empty()) {
    fs::remove(partial_path);
    throw std::runtime_error(name + ": checksum mismatch: the download has " + mismatch +
                             " (the download was removed; run the command again)");
  }
  fs::rename(partial_path, blob);
}

}  // namespace

std::string ModelReference::text() const {
  std::string text = kPrefix + repo;
  if (!file.empty()) text += "/" + file;
  if (revision != "main") text += "@" + revision;
  return text;
}

const std::vector<ShortName>& short_names() {
  static const std::vector<ShortName> names = {
      {"moge-2-vits-normal", "Ruicheng/moge-2-vits-normal",
       "MoGe-2 ViT-S with normals (35 M parameters)"},
      {"moge-2-vitb-normal", "Ruicheng/moge-2-vitb-normal",
       "MoGe-2 ViT-B with normals (104 M parameters)"},
      {"moge-2-vitl-normal", "Ruicheng/moge-2-vitl-normal",
       "MoGe-2 ViT-L with normals (331 M parameters; MoGe's recommended model)"},
      {"moge-2-vitl", "Ruicheng/moge-2-vitl", "MoGe-2 ViT-L without the normal head (326 M)"},
  };
  return names;
}

bool is_model_reference(const std::string& model) {
  if (model.rfind(kPrefix, 0) == 0) return true;
  std::error_code error;
  return find_short_name(leading_name(model)) != nullptr && !fs::exists(model, error);
}

ModelReference parse_model_reference(const std::string& text) {
  std::string body = text.rfind(kPrefix, 0) == 0 ? text.substr(3) : text;
  ModelReference reference;
  if (const auto at = body.rfind('@'); at != std::string::npos) {
    reference.revision = body.substr(at + 1);
    body = body.substr(0, at);
  }
  const std::string lead = leading_name(body);
  if (const ShortName* known = find_short_name(lead)) {
    reference.repo = known->repo;
    if (body.size() > lead.size()) reference.file = body.substr(lead.size() + 1);
  } else {
    const auto first = body.find('/');
    const auto second = first == std::string::npos ? std::string::npos : body.find('/', first + 1);
    reference.repo = body.substr(0, second);
    if (second != std::string::npos) reference.file = body.substr(second + 1);
    if (first == std::string::npos)
      throw std::invalid_argument(
          "model " + text + ": \"" + body +
          "\" is no short name and not OWNER/REPO (short names: " + short_name_list() + ")");
  }
  check_reference(reference, text);
  return reference;
}

std::vector<std::string> checkpoint_files(const std::string& model_info,
                                          const std::string& source) {
  std::vector<std::string> files;
  try {
    const nlohmann::json info = nlohmann::json::parse(model_info);
    for (const nlohmann::json& sibling : info.at("siblings")) {
      const std::string file = sibling.at("rfilename").get<std::string>();
      if (!is_checkpoint_file(file)) continue;
      // The name becomes a path in the cache.
      if (!is_repository_path(file))
        throw std::runtime_error(source + " lists the file \"" + file +
                                 "\", which is no path inside the repository");
      files.push_back(file);
    }
  } catch (const nlohmann::json::exception&) {
    throw std::runtime_error(source +
                             " is not a model description with a \"siblings\" list of "
                             "{\"rfilename\": ...}");
  }
  std::sort(files.begin(), files.end());
  return files;
}

bool is_checkpoint_file(const std::string& name) {
  const std::string extension = fs::path(name).extension().string();
  return extension == ".safetensors" || extension == ".pt" || extension == ".pth";
}

Settings Settings::from_environment() {
  Settings settings;
  if (std::string endpoint = environment("HF_ENDPOINT"); !endpoint.empty()) {
    while (!endpoint.empty() && endpoint.back() == '/') endpoint.pop_back();
    settings.endpoint = endpoint;
  }
  settings.token = environment("HF_TOKEN");
  settings.offline = truthy(environment("HF_HUB_OFFLINE"));
  if (const std::string cache = environment("OMNIPOINT_CACHE"); !cache.empty()) {
    settings.cache = cache;
  } else if (const std::string xdg = environment("XDG_CACHE_HOME"); !xdg.empty()) {
    settings.cache = fs::path(xdg) / "omnipoint";
  } else if (const std::string home = environment("HOME"); !home.empty()) {
    settings.cache = fs::path(home) / ".cache" / "omnipoint";
  } else {
    throw std::runtime_error(
        "no cache folder for downloaded models: set OMNIPOINT_CACHE (or XDG_CACHE_HOME or HOME)");
  }
  return settings;
}

CachedModel fetch_model(const ModelReference& reference, const Settings& settings,
                        DownloadObserver* observer) {
  DownloadObserver silent;
  DownloadObserver& report = observer != nullptr ? *observer : silent;
  const std::string name = reference.text();
  const auto cached_or = [&](const std::string& why) {
    if (std::optional<CachedModel> cached = find_cached(reference, settings.cache)) return *cached;
    throw std::runtime_error(name + ": " + why);
  };
  if (settings.offline)
    return cached_or("HF_HUB_OFFLINE is set and the cache (" + settings.cache.string() +
                     ") holds no copy: fetch it once while online (omnipoint models pull " + name +
                     ")");
  ModelReference resolved = reference;
  FileFacts facts;
  try {
    if (resolved.file.empty()) resolved.file = the_checkpoint_file(resolved, settings);
    facts = file_facts(resolved, settings);
  } catch (const HttpUnreachable& e) {
    if (std::optional<CachedModel> cached = find_cached(reference, settings.cache)) {
      report.note("cannot reach the hub (" + std::string(e.what()) + "): using the cached copy " +
                  cached->reference.text() + " of commit " + cached->commit);
      return *cached;
    }
    fail_unreachable(name, e);
  }
  const std::string commit = facts.commit.empty() ? resolved.revision : facts.commit;
  // The commit names a cache folder: a name the hub could not mean is refused.
  if (!facts.commit.empty() && !valid_name(facts.commit))
    throw std::runtime_error(name + ": the hub named the commit \"" + facts.commit +
                             "\", which is no commit name");
  const fs::path repo = repo_folder(settings.cache, resolved.repo);
  const std::string blob = blob_name(facts.etag);
  const fs::path blob_path = repo / "blobs" / blob;
  bool downloaded = false;
  if (!fs::exists(blob_path)) {
    try {
      download_blob(resolved.text(), facts, blob_path, settings, report);
    } catch (const HttpUnreachable& e) {
      fail_unreachable(resolved.text(), e);
    }
    downloaded = true;
  }
  CachedModel model = enter(resolved, settings.cache, commit, blob);
  model.downloaded = downloaded;
  return model;
}

std::vector<CachedModel> cached_models(const fs::path& cache) {
  std::vector<CachedModel> models;
  const fs::path hub = cache / "hub";
  std::error_code error;
  if (!fs::is_directory(hub, error)) return models;
  std::vector<fs::path> repos;
  for (const fs::directory_entry& entry : fs::directory_iterator(hub, error))
    if (entry.is_directory() && entry.path().filename().string().rfind("models--", 0) == 0)
      repos.push_back(entry.path());
  std::sort(repos.begin(), repos.end());
  for (const fs::path& repo : repos) {
    std::string name = repo.filename().string().substr(8);
    const auto separator = name.find("--");
    if (separator == std::string::npos) continue;
    name.replace(separator, 2, "/");
    // Which revisions point at each commit.
    std::map<std::string, std::string> revision_of;
    for (const fs::directory_entry& ref : fs::directory_iterator(repo / "refs", error)) {
      std::string commit = read_file(ref.path().string());
      commit.erase(commit.find_last_not_of(" \n\r\t") + 1);
      const std::string revision = ref_revision(ref.path().filename().string());
      std::string& names = revision_of[commit];
      names = names.empty() || revision == "main" ? revision : names;
    }
    std::vector<fs::path> snapshots;
    for (const fs::directory_entry& entry : fs::directory_iterator(repo / "snapshots", error))
      if (entry.is_directory()) snapshots.push_back(entry.path());
    std::sort(snapshots.begin(), snapshots.end());
    for (const fs::path& snapshot : snapshots) {
      for (const std::string& file : snapshot_checkpoints(snapshot)) {
        CachedModel model;
        model.commit = snapshot.filename().string();
        model.reference.repo = name;
        model.reference.file = file;
        const auto revision = revision_of.find(model.commit);
        model.reference.revision = revision != revision_of.end() ? revision->second : model.commit;
        model.path = snapshot / file;
        model.bytes = static_cast<std::int64_t>(fs::file_size(model.path, error));
        models.push_back(std::move(model));
      }
    }
  }
  return models;
}

std::string resolve_model_path(const std::string& model, const Settings& settings,
                               DownloadObserver* observer) {
  if (!is_model_reference(model)) return model;
  return fetch_model(parse_model_reference(model), settings, observer).path.string();
}

std::string human_bytes(std::int64_t bytes) {
  const char* units[] = {"B", "kB", "MB", "GB", "TB"};
  double value = static_cast<double>(bytes);
  int unit = 0;
  while (value >= 1000 && unit < 4) {
    value /= 1000;
    ++unit;
  }
  char text[32];
  if (unit == 0)
    std::snprintf(text, sizeof text, "%lld B", static_cast<long long>(bytes));
  else
    std::snprintf(text, sizeof text,
                  value < 10    ? "%.2f %s"
                  : value < 100 ? "%.1f %s"
                                : "%.0f %s",
                  value, units[unit]);
  return text;
}

}  // namespace omnipoint::io::hub
