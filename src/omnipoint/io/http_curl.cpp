// io/http.h on libcurl's easy interface.
#include <curl/curl.h>

#include <algorithm>
#include <cctype>
#include <memory>
#include <mutex>

#include "omnipoint/io/http.h"

namespace omnipoint::io {

namespace {

constexpr std::size_t kErrorBodyBytes = 4096;  // what an error answer's body keeps

struct CurlDeleter {
  void operator()(CURL* curl) const { curl_easy_cleanup(curl); }
};
struct HeaderListDeleter {
  void operator()(curl_slist* list) const { curl_slist_free_all(list); }
};
using Curl = std::unique_ptr<CURL, CurlDeleter>;
using HeaderList = std::unique_ptr<curl_slist, HeaderListDeleter>;

std::string lower(std::string text) {
  std::transform(text.begin(), text.end(), text.begin(),
                 [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  return text;
}

std::string trimmed(const std::string& text) {
  const auto begin = text.find_first_not_of(" \t\r\n");
  if (begin == std::string::npos) return "";
  return text.substr(begin, text.find_last_not_of(" \t\r\n") - begin + 1);
}

// One request's state, shared with curl's callbacks.
struct Exchange {
  CURL* curl = nullptr;
  HttpResponse response;
  const HttpSink* sink = nullptr;  // a download's; null: the body goes to response.body
  std::size_t max_body = 0;        // for response.body
  bool too_large = false;
  bool accepted = false;  // the final answer is a 2xx the sink takes
  bool decided = false;   // whether the first body byte has been seen
};

// Headers of each answer in turn (redirects included): a status line starts a new set, so the
// final answer's remain.
std::size_t on_header(char* data, std::size_t size, std::size_t count, void* user) {
  Exchange& exchange = *static_cast<Exchange*>(user);
  const std::string line(data, size * count);
  if (line.rfind("HTTP/", 0) == 0) {
    exchange.response.headers.clear();
  } else if (const auto colon = line.find(':'); colon != std::string::npos) {
    exchange.response.headers[lower(trimmed(line.substr(0, colon)))] =
        trimmed(line.substr(colon + 1));
  }
  return size * count;
}

std::size_t on_body(char* data, std::size_t size, std::size_t count, void* user) {
  Exchange& exchange = *static_cast<Exchange*>(user);
  const std::size_t bytes = size * count;
  if (!exchange.decided) {
    exchange.decided = true;
    curl_easy_getinfo(exchange.curl, CURLINFO_RESPONSE_CODE, &exchange.response.status);
    const long status = exchange.response.status;
    exchange.accepted = exchange.sink != nullptr && (status == 200 || status == 206);
    if (exchange.accepted && exchange.sink->begin) exchange.sink->begin(status == 206);
  }
  if (exchange.accepted) return exchange.sink->write(data, bytes) ? bytes : 0;
  std::string& body = exchange.response.body;
  const std::size_t limit = exchange.sink != nullptr ? kErrorBodyBytes : exchange.max_body;
  if (body.size() + bytes > limit) {
    if (exchange.sink != nullptr) {  // an error page: its start is enough
      body.append(data, limit - std::min(limit, body.size()));
      return bytes;
    }
    exchange.too_large = true;
    return 0;
  }
  body.append(data, bytes);
  return bytes;
}

int on_progress(void* user, curl_off_t total, curl_off_t received, curl_off_t, curl_off_t) {
  const Exchange& exchange = *static_cast<const Exchange*>(user);
  if (exchange.accepted && exchange.sink->progress)
    exchange.sink->progress(received, total > 0 ? total : -1);
  return 0;
}

void global_init() {
  static std::once_flag once;
  std::call_once(once, [] {
    if (curl_global_init(CURL_GLOBAL_DEFAULT) != CURLE_OK)
      throw std::runtime_error("HTTP: libcurl could not be initialised");
  });
}

// An easy handle with what every request shares.
Curl new_handle(const std::string& url, const HttpOptions& options, Exchange& exchange,
                curl_slist* headers) {
  global_init();
  Curl curl(curl_easy_init());
  if (!curl) throw std::runtime_error("HTTP: libcurl could not make a request");
  CURL* c = curl.get();
  exchange.curl = c;
  curl_easy_setopt(c, CURLOPT_URL, url.c_str());
  curl_easy_setopt(c, CURLOPT_NOSIGNAL, 1L);
#if LIBCURL_VERSION_NUM >= 0x075500  // 7.85: the protocol lists as text
  curl_easy_setopt(c, CURLOPT_PROTOCOLS_STR, "http,https");
  curl_easy_setopt(c, CURLOPT_REDIR_PROTOCOLS_STR, "http,https");
#else
  curl_easy_setopt(c, CURLOPT_PROTOCOLS, CURLPROTO_HTTP | CURLPROTO_HTTPS);
  curl_easy_setopt(c, CURLOPT_REDIR_PROTOCOLS, CURLPROTO_HTTP | CURLPROTO_HTTPS);
#endif
  curl_easy_setopt(c, CURLOPT_USERAGENT, "omnipoint/" OMNIPOINT_VERSION " libcurl");
  curl_easy_setopt(c, CURLOPT_CONNECTTIMEOUT, options.connect_timeout_s);
  // Stalled: under one byte a second for stall_timeout_s.
  curl_easy_setopt(c, CURLOPT_LOW_SPEED_LIMIT, 1L);
  curl_easy_setopt(c, CURLOPT_LOW_SPEED_TIME, options.stall_timeout_s);
  curl_easy_setopt(c, CURLOPT_MAXREDIRS, 10L);
  if (!options.bearer_token.empty()) {
    curl_easy_setopt(c, CURLOPT_HTTPAUTH, CURLAUTH_BEARER);
    curl_easy_setopt(c, CURLOPT_XOAUTH2_BEARER, options.bearer_token.c_str());
  }
  curl_easy_setopt(c, CURLOPT_HTTPHEADER, headers);
  curl_easy_setopt(c, CURLOPT_HEADERFUNCTION, on_header);
  curl_easy_setopt(c, CURLOPT_HEADERDATA, &exchange);
  curl_easy_setopt(c, CURLOPT_WRITEFUNCTION, on_body);
  curl_easy_setopt(c, CURLOPT_WRITEDATA, &exchange);
  return curl;
}

// Whether curl's failure means that no answer came (rather than one cut short).
bool no_answer(CURLcode code) {
  switch (code) {
    case CURLE_COULDNT_RESOLVE_PROXY:
    case CURLE_COULDNT_RESOLVE_HOST:
    case CURLE_COULDNT_CONNECT:
    case CURLE_SSL_CONNECT_ERROR:
    case CURLE_PEER_FAILED_VERIFICATION:
    case CURLE_SSL_CACERT_BADFILE:
    case CURLE_UNSUPPORTED_PROTOCOL:
    case CURLE_URL_MALFORMAT:
      return true;
    default:
      return false;
  }
}

// Runs the request; HttpUnreachable when no answer came at all.
CURLcode perform(CURL* curl, const std::string& url, Exchange& exchange, char* error) {
  curl_easy_setopt(curl, CURLOPT_ERRORBUFFER, error);
  error[0] = '\0';
  const CURLcode code = curl_easy_perform(curl);
  curl_easy_getinfo(curl, CURLINFO_RESPONSE_CODE, &exchange.response.status);
  char* effective = nullptr;
  curl_easy_getinfo(curl, CURLINFO_EFFECTIVE_URL, &effective);
  exchange.response.url = effective != nullptr ? effective : url;
  if (code != CURLE_OK && (exchange.response.status == 0 || no_answer(code)))
    throw HttpUnreachable(url + ": " + (error[0] != '\0' ? error : curl_easy_strerror(code)));
  return code;
}

std::string describe(CURLcode code, const char* error) {
  return error[0] != '\0' ? error : curl_easy_strerror(code);
}

}  // namespace

bool http_available() {
  return true;
}

HttpResponse http_head(const std::string& url, const HttpOptions& options) {
  Exchange exchange;
  // The size of the file, not of a compressed answer (the hub's client asks the same).
  const HeaderList headers(curl_slist_append(nullptr, "Accept-Encoding: identity"));
  const Curl curl = new_handle(url, options, exchange, headers.get());
  curl_easy_setopt(curl.get(), CURLOPT_NOBODY, 1L);
  char error[CURL_ERROR_SIZE];
  const CURLcode code = perform(curl.get(), url, exchange, error);
  if (code != CURLE_OK) throw HttpUnreachable(url + ": " + describe(code, error));
  return exchange.response;
}

HttpResponse http_get(const std::string& url, const HttpOptions& options, std::size_t max_bytes) {
  Exchange exchange;
  exchange.max_body = max_bytes;
  const Curl curl = new_handle(url, options, exchange, nullptr);
  curl_easy_setopt(curl.get(), CURLOPT_FOLLOWLOCATION, 1L);
  char error[CURL_ERROR_SIZE];
  const CURLcode code = perform(curl.get(), url, exchange, error);
  if (exchange.too_large)
    throw std::runtime_error(url + ": the answer is larger than " + std::to_string(max_bytes) +
                             " bytes");
  if (code != CURLE_OK) throw HttpUnreachable(url + ": " + describe(code, error));
  return exchange.response;
}

HttpTransfer http_download(const std::string& url, std::int64_t offset, const HttpOptions& options,
                           const HttpSink& sink) {
  Exchange exchange;
  exchange.sink = &sink;
  const Curl curl = new_handle(url, options, exchange, nullptr);
  CURL* c = curl.get();
  curl_easy_setopt(c, CURLOPT_FOLLOWLOCATION, 1L);
  const std::string range = std::to_string(offset) + "-";
  if (offset > 0) curl_easy_setopt(c, CURLOPT_RANGE, range.c_str());
  curl_easy_setopt(c, CURLOPT_NOPROGRESS, 0L);
  curl_easy_setopt(c, CURLOPT_XFERINFOFUNCTION, on_progress);
  curl_easy_setopt(c, CURLOPT_XFERINFODATA, &exchange);
  char error[CURL_ERROR_SIZE];
  const CURLcode code = perform(c, url, exchange, error);
  HttpTransfer transfer;
  transfer.response = exchange.response;
  const long status = transfer.response.status;
  const bool success = status >= 200 && status < 300;
  transfer.complete = code == CURLE_OK && success;
  if (code != CURLE_OK && success) transfer.error = describe(code, error);
  return transfer;
}

}  // namespace omnipoint::io
