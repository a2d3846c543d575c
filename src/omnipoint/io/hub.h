#pragma once
// Published checkpoints by name: files of Hugging Face hub repositories, downloaded into a local
// cache with the hub's conventions (its own client, huggingface_hub, follows the same):
//
//   hf:OWNER/REPO[/FILE][@REVISION]   a file of a repository at a branch, tag or commit (default
//                                     main); without FILE the repository's one checkpoint file
//                                     (.safetensors, .pt, .pth), found in the model API's list
//                                     GET ENDPOINT/api/models/OWNER/REPO[/revision/REVISION]
//   moge-2-vitl-normal, ...           short names of the published MoGe-2 checkpoints
//                                     (short_names(); "hf:" in front is allowed)
//
// A file is ENDPOINT/OWNER/REPO/resolve/REVISION/FILE. Its HEAD answer (redirects not followed:
// large files redirect to a CDN) carries the facts: X-Repo-Commit (the commit the revision is
// at), X-Linked-Etag and X-Linked-Size for files in Git LFS (the ETag is the content's SHA-256),
// else ETag (Git's blob SHA-1) and Content-Length. The GET follows the redirects; the token is
// not sent to another host.
//
// Environment (Settings::from_environment): HF_ENDPOINT (default https://huggingface.co),
// HF_TOKEN (a bearer token for gated or private repositories), HF_HUB_OFFLINE=1 (the cache
// only: no request is made), OMNIPOINT_CACHE (default $XDG_CACHE_HOME/omnipoint, else
// ~/.cache/omnipoint).
//
// The cache (below CACHE/hub/), one folder per repository, models--OWNER--REPO/:
//   blobs/ETAG                   a verified file, named by its hub ETag
//   blobs/ETAG.incomplete        a download under way or interrupted: the next one resumes it
//                                (HTTP Range) under an exclusive lock, so concurrent processes
//                                never write it together
//   refs/REVISION                the commit the revision resolved to ('/' written as %2F)
//   snapshots/COMMIT/FILE        a symbolic link to its blob: the path fetch_model returns
// A file enters blobs/ by a rename once its size and checksum are verified, and only then gets
// its snapshot link: the cache never holds a half file under a final name. A checksum mismatch
// removes the download.
//
// Errors are std::runtime_error (std::invalid_argument for a malformed reference) with one line:
// no network (HttpUnreachable, io/http.h), access denied (401/403: gated, needs HF_TOKEN), not
// found (404, naming the URL), a checksum or size mismatch, offline without a cached copy.
#include <cstdint>
#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include "omnipoint/io/http.h"

namespace omnipoint::io::hub {

struct ModelReference {
  std::string repo;               // OWNER/REPO
  std::string file;               // a path in the repository; "": its one checkpoint file
  std::string revision = "main";  // a branch, tag or commit
  // hf:OWNER/REPO[/FILE][@REVISION] (the revision left out when it is main).
  std::string text() const;
};

// A published checkpoint known by a short name.
struct ShortName {
  std::string name;         // "moge-2-vitl-normal"
  std::string repo;         // "Ruicheng/moge-2-vitl-normal"
  std::string description;  // one line
};
const std::vector<ShortName>& short_names();

// Whether `model` (a --model value) names a hub file rather than a local one: it starts with
// "hf:", or it is a short name (alone or with /FILE, @REVISION) and no file of that name exists.
bool is_model_reference(const std::string& model);
// The reference `text` names (the forms above). std::invalid_argument with one line naming
// the problem: an unknown short name, a repository that is not OWNER/REPO, an empty or ".."
// path component, a bad revision.
ModelReference parse_model_reference(const std::string& text);

// Whether a repository file is a checkpoint: .safetensors, .pt or .pth.
bool is_checkpoint_file(const std::string& name);

// The checkpoint files a model API answer (GET /api/models/OWNER/REPO) lists in "siblings"
// ([{"rfilename": PATH}, ...]), sorted. std::runtime_error starting with `source`: the text is
// no such description, or a checkpoint's name is no path inside the repository (absolute,
// "..": it would land outside the cache).
std::vector<std::string> checkpoint_files(const std::string& model_info, const std::string& source);

struct Settings {
  std::string endpoint = "https://huggingface.co";  // no trailing '/'
  std::string token;                                // "": none
  bool offline = false;
  std::filesystem::path cache;  // the cache root (CACHE above)
  int attempts = 3;             // transfers a download tries, each resuming the last
  HttpOptions http;             // timeouts (the token is added per request)

  // From the environment (above); std::runtime_error when no cache folder can be named (no
  // OMNIPOINT_CACHE, XDG_CACHE_HOME or HOME).
  static Settings from_environment();
};

// What a download reports; every hook does nothing unless overridden. Calls come from the
// thread that calls fetch_model.
class DownloadObserver {
 public:
  virtual ~DownloadObserver() = default;
  // A transfer starts: `name` (hf:...), the file's size (-1 when the hub does not say) and the
  // bytes a partial file already holds (> 0: resumed).
  virtual void started(const std::string& /*name*/, std::int64_t /*bytes*/,
                       std::int64_t /*resumed_at*/) {}
  // Bytes of the file present so far (the resumed part included).
  virtual void progress(std::int64_t /*present*/, std::int64_t /*bytes*/) {}
  // The transfer ended (verified or not).
  virtual void finished() {}
  // Something a user should know: a dropped connection being resumed, the cached copy used
  // while the hub cannot be reached.
  virtual void note(const std::string& /*text*/) {}
};

struct CachedModel {
  ModelReference reference;    // with the file filled in
  std::string commit;          // the snapshot's commit (or revision, where the hub named none)
  std::filesystem::path path;  // snapshots/COMMIT/FILE
  std::int64_t bytes = 0;
  bool downloaded = false;  // fetched by this call rather than found in the cache
};

// The local file of `reference`: the cached copy when it is the hub's current one (a HEAD
// request tells; offline, the cached copy of the revision), else downloaded, verified and
// cached. While the hub cannot be reached, a cached copy of the revision is used with a note.
CachedModel fetch_model(const ModelReference& reference, const Settings& settings,
                        DownloadObserver* observer = nullptr);

// The cache's files, one per snapshot file, by repository and file; reference.revision is a
// revision that resolved to the commit (the commit itself where none did).
std::vector<CachedModel> cached_models(const std::filesystem::path& cache);

// --model's rule: a hub reference is fetched and its local path returned; anything else is a
// file path, returned as it is.
std::string resolve_model_path(const std::string& model, const Settings& settings,
                               DownloadObserver* observer = nullptr);

// "1.32 GB", "820 kB", "512 B" (powers of 1000).
std::string human_bytes(std::int64_t bytes);

}  // namespace omnipoint::io::hub
