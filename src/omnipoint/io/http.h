#pragma once
// HTTP(S) requests for the hub client (io/hub.h), on Debian's libcurl: the optional edge module
// of builds with OMNIPOINT_WITH_HUB. Without it every request throws std::runtime_error saying
// so; http_available() tells beforehand. Proxies follow curl's environment (https_proxy,
// no_proxy).
#include <cstdint>
#include <functional>
#include <map>
#include <stdexcept>
#include <string>

namespace omnipoint::io {

bool http_available();

// A request that got no HTTP answer: no network, a name that does not resolve, a refused or
// timed-out connection, a TLS failure. The message says which and names the URL.
class HttpUnreachable : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

struct HttpOptions {
  // Sent as "Authorization: Bearer TOKEN" to the URL's host only: curl drops it on a redirect
  // to another host or port (the hub's CDN), as the hub's own client does. "": none.
  std::string bearer_token;
  long connect_timeout_s = 20;
  long stall_timeout_s = 60;  // a transfer that moves no byte for this long is abandoned
};

struct HttpResponse {
  long status = 0;
  std::map<std::string, std::string> headers;  // the final response's, names in lower case
  std::string body;                            // http_get's; an error answer's start otherwise
  std::string url;                             // the final URL, after the redirects followed
};

// A HEAD request; redirects are not followed (the answer is the first server's).
HttpResponse http_head(const std::string& url, const HttpOptions& options);

// A GET into memory, redirects followed; a body over `max_bytes` is an error.
HttpResponse http_get(const std::string& url, const HttpOptions& options,
                      std::size_t max_bytes = std::size_t{16} << 20);

// Where a download's body goes.
struct HttpSink {
  // Called once when the final answer is 200 or 206, before its first byte: `partial` is true
  // for 206 (the body continues at the requested offset), false for 200 (it starts at byte 0).
  std::function<void(bool partial)> begin;
  // The body's bytes, in order; false stops the transfer.
  std::function<bool(const char* data, std::size_t size)> write;
  // Bytes of this transfer so far, and its length (-1 when the server does not say).
  std::function<void(std::int64_t received, std::int64_t length)> progress;
};

struct HttpTransfer {
  HttpResponse response;  // any status; an error answer's body is not given to the sink
  bool complete = false;  // the whole body arrived (a 2xx answer)
  std::string error;      // why not, when a 2xx body stopped short (a dropped connection)
};

// A GET streamed into `sink`, redirects followed (the Range header travels with them); from
// byte `offset` on with "Range: bytes=OFFSET-" when offset > 0. HttpUnreachable when no
// answer came.
HttpTransfer http_download(const std::string& url, std::int64_t offset, const HttpOptions& options,
                           const HttpSink& sink);

}  // namespace omnipoint::io
