#include <diffreg/serve/connection.h>

#include <arpa/inet.h>
#include <netdb.h>
#include <poll.h>
#include <sys/socket.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstring>
#include <string>

namespace diffreg {
namespace {

using Clock = std::chrono::steady_clock;

// Set by closeAfterResponse() in the worker thread that is answering the request.
thread_local bool t_closeAfterResponse = false;

/// poll() for one event, retried on EINTR; true when it came within `ms`.
bool waitFor(socket_t sock, short event, int ms) {
  pollfd p{sock, event, 0};
  for (;;) {
    const int r = ::poll(&p, 1, std::max(ms, 0));
    if (r < 0 && errno == EINTR) continue;
    return r > 0 && (p.revents & (event | POLLHUP | POLLERR)) != 0;
  }
}

void addressOf(socket_t sock, bool peer, std::string& ip, int& port) {
  sockaddr_storage addr{};
  socklen_t length = sizeof addr;
  const int r = peer ? ::getpeername(sock, reinterpret_cast<sockaddr*>(&addr), &length)
                     : ::getsockname(sock, reinterpret_cast<sockaddr*>(&addr), &length);
  if (r != 0) return;
  char host[NI_MAXHOST], service[NI_MAXSERV];
  if (::getnameinfo(reinterpret_cast<sockaddr*>(&addr), length, host, sizeof host, service,
                    sizeof service, NI_NUMERICHOST | NI_NUMERICSERV) == 0) {
    ip = host;
    port = std::atoi(service);
  }
}

/// httplib's Stream over a socket: buffered reads that each wait at most the read timeout and
/// fail once the current request's deadline has passed; writes that wait at most the write
/// timeout.
class DeadlineStream : public httplib::Stream {
 public:
  DeadlineStream(socket_t sock, std::chrono::milliseconds readTimeout,
                 std::chrono::milliseconds writeTimeout, std::chrono::milliseconds answerTime)
      : sock_(sock),
        readTimeout_(readTimeout),
        writeTimeout_(writeTimeout),
        answerTime_(answerTime) {}

  void startRequest(Clock::time_point deadline) {
    deadline_ = deadline;
    answerDeadline_ = Clock::time_point::max();
  }
  /// Bytes received and not yet read: the start of a next request.
  bool buffered() const { return begin_ < end_; }
  /// A read has failed (the deadline, a second of silence, or the peer's end): the request was
  /// cut off, and nothing after it on this connection is a request.
  bool failed() const { return failed_; }

  bool is_readable() const override {
    // Nothing more of a request past its deadline, even what has arrived already.
    if (Clock::now() >= deadline_) return false;
    return begin_ < end_ || waitFor(sock_, POLLIN, millisecondsLeft());
  }
  bool is_writable() const override {
    // A response must be taken within answerTime of its first byte: a client that reads a few
    // bytes now and then holds no worker for longer.
    const auto left =
        std::chrono::ceil<std::chrono::milliseconds>(answerDeadline_ - Clock::now()).count();
    if (left <= 0) return false;
    return waitFor(sock_, POLLOUT,
                   static_cast<int>(std::min<long long>(left, writeTimeout_.count())));
  }
  ssize_t read(char* ptr, size_t size) override {
    if (begin_ == end_) {
      if (!is_readable()) {
        failed_ = true;
        return -1;
      }
      ssize_t n;
      do n = ::recv(sock_, buffer_, sizeof buffer_, 0);
      while (n < 0 && errno == EINTR);
      if (n <= 0) {
        failed_ = true;
        return n;
      }
      begin_ = 0;
      end_ = static_cast<size_t>(n);
    }
    const size_t n = std::min(size, end_ - begin_);
    std::memcpy(ptr, buffer_ + begin_, n);
    begin_ += n;
    return static_cast<ssize_t>(n);
  }
  ssize_t write(const char* ptr, size_t size) override {
    if (answerDeadline_ == Clock::time_point::max()) answerDeadline_ = Clock::now() + answerTime_;
    if (!is_writable()) return -1;
    ssize_t n;
    do n = ::send(sock_, ptr, size, MSG_NOSIGNAL);
    while (n < 0 && errno == EINTR);
    return n;
  }
  void get_remote_ip_and_port(std::string& ip, int& port) const override {
    addressOf(sock_, true, ip, port);
  }
  void get_local_ip_and_port(std::string& ip, int& port) const override {
    addressOf(sock_, false, ip, port);
  }
  socket_t socket() const override { return sock_; }

 private:
  /// The read timeout, cut to what is left until the deadline (rounded up: a wait that ends
  /// early would cut the request off before it).
  int millisecondsLeft() const {
    const auto left = std::chrono::ceil<std::chrono::milliseconds>(deadline_ - Clock::now());
    return static_cast<int>(std::max<long long>(0, std::min(left, readTimeout_).count()));
  }

  socket_t sock_;
  std::chrono::milliseconds readTimeout_, writeTimeout_, answerTime_;
  Clock::time_point deadline_ = Clock::time_point::max();
  Clock::time_point answerDeadline_ = Clock::time_point::max();
  char buffer_[4096];
  size_t begin_ = 0, end_ = 0;
  bool failed_ = false;
};

}  // namespace

void DeadlineServer::closeAfterResponse() { t_closeAfterResponse = true; }

bool DeadlineServer::nextRequestArrives(socket_t sock) const {
  // In slices, so that stop() (which closes the listening socket) ends idle connections soon.
  const auto until = Clock::now() + std::chrono::seconds(keep_alive_timeout_sec_);
  while (svr_sock_ != INVALID_SOCKET) {
    const auto left =
        std::chrono::duration_cast<std::chrono::milliseconds>(until - Clock::now()).count();
    if (left <= 0) return false;
    if (waitFor(sock, POLLIN, static_cast<int>(std::min<long long>(left, 100)))) return true;
  }
  return false;
}

bool DeadlineServer::process_and_close_socket(socket_t sock) {
  using std::chrono::milliseconds;
  const auto ms = [](time_t sec, time_t usec) { return milliseconds(sec * 1000 + usec / 1000); };
  DeadlineStream stream(sock, ms(read_timeout_sec_, read_timeout_usec_),
                        ms(write_timeout_sec_, write_timeout_usec_), requestTime_);
  bool ok = false;
  // A request already read along with the previous one (pipelined) needs no wait.
  for (size_t left = keep_alive_max_count_;
       left > 0 && (stream.buffered() || nextRequestArrives(sock)); --left) {
    stream.startRequest(Clock::now() + requestTime_);
    bool closed = false;
    t_closeAfterResponse = false;
    ok = process_request(stream, left == 1, closed, nullptr);
    if (t_closeAfterResponse) break;
    // A request cut off (at its deadline, or by silence) was answered 400; what the client
    // trickles after it must not start another request, and deadline, on this connection.
    if (!ok || closed || stream.failed()) break;
  }
  ::shutdown(sock, SHUT_RDWR);
  ::close(sock);
  return ok;
}

}  // namespace diffreg
