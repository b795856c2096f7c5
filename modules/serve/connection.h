// One connection of `diffreg serve`: cpp-httplib's server with a deadline per request. httplib
// alone times out each read (a second of silence closes the connection), so a client that sends
// a byte every 0.9 s would hold a worker for as long as it likes; here the request line, the
// headers and the body must all arrive within `requestSeconds` of the request's first byte, and
// the response must be taken within as long of its first byte.
#pragma once

#include <httplib.h>

#include <chrono>

namespace diffreg {

class DeadlineServer : public httplib::Server {
 public:
  explicit DeadlineServer(std::chrono::milliseconds requestTime) : requestTime_(requestTime) {}

  /// From a handler: the connection ends after this response. A request refused before its
  /// body was read must end it, or the unread body would be read as the next request (and a
  /// body can be any request, with its own headers). httplib ignores "Connection: close" set
  /// on a response.
  static void closeAfterResponse();

 private:
  // httplib calls this for every accepted socket (from its worker threads): the keep-alive loop
  // of httplib's own, with a stream whose reads stop at the request's deadline.
  bool process_and_close_socket(socket_t sock) override;
  /// Waits up to the keep-alive timeout for the next request; false when none comes or the
  /// server stops.
  bool nextRequestArrives(socket_t sock) const;

  std::chrono::milliseconds requestTime_;
};

}  // namespace diffreg
