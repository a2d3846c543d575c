// io/http.h in a build without libcurl (OMNIPOINT_WITH_HUB=OFF): every request says so.
#include "omnipoint/io/http.h"

namespace omnipoint::io {

namespace {

[[noreturn]] void unavailable() {
  throw std::runtime_error(
      "this omnipoint was built without an HTTP client (OMNIPOINT_WITH_HUB=OFF: no libcurl), so it "
      "cannot download; pass a local checkpoint file");
}

}  // namespace

bool http_available() {
  return false;
}

HttpResponse http_head(const std::string&, const HttpOptions&) {
  unavailable();
}

HttpResponse http_get(const std::string&, const HttpOptions&, std::size_t) {
  unavailable();
}

HttpTransfer http_download(const std::string&, std::int64_t, const HttpOptions&, const HttpSink&) {
  unavailable();
}

}  // namespace omnipoint::io
