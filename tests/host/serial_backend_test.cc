// SerialBackend against in-test peers that act as the robot: the master side
// of a pty (posix_openpt; the backend opens a symlink to the slave) and a TCP
// listener on an ephemeral loopback port. The peer decodes what the backend
// sends and answers like a module (and, when it plays yamor-bridge, answers
// the GetSimInfo hello).
#include "host/serial_backend.h"

#include <arpa/inet.h>
#include <fcntl.h>
#include <netinet/in.h>
#include <netinet/tcp.h>
#include <poll.h>
#include <stdlib.h>
#include <sys/socket.h>
#include <termios.h>
#include <unistd.h>

#include <atomic>
#include <chrono>
#include <cstring>
#include <filesystem>
#include <memory>
#include <mutex>
#include <random>
#include <string>
#include <thread>
#include <vector>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "common/status.h"
#include "proto/snp/decoder.h"
#include "proto/snp/messages.h"

namespace yamor::host {
namespace {

using namespace std::chrono_literals;
using ::testing::HasSubstr;
using Clock = std::chrono::steady_clock;

constexpr snp::SimInfo kSimInfo{.time_step = 0.001, .accelerometer_zero = 512.0,
                                .accelerometer_count = 0.0478};

double SecondsSince(Clock::time_point start) {
  return std::chrono::duration<double>(Clock::now() - start).count();
}

// Writes every byte to a blocking descriptor; false once the peer is gone.
bool WriteAll(int fd, const uint8_t* data, std::size_t size) {
  while (size > 0) {
    const ssize_t n = ::write(fd, data, size);
    if (n < 0) {
      if (errno == EINTR) continue;
      return false;
    }
    data += n;
    size -= static_cast<std::size_t>(n);
  }
  return true;
}

// The robot end of a link: serves one descriptor on its own thread. Frames
// it receives are recorded; module requests to a unicast module are answered
// (ReadServoAngle with ServoAngle 0.25, anything else with Ack OK); the hello
// is answered with SimInfo when the peer plays the bridge, ignored otherwise
// (a real robot never answers bridge specials).
class PeerCore {
 public:
  virtual ~PeerCore() { StopServing(); }

  // Plays yamor-bridge (answers the hello) or a real robot.
  void set_bridge(bool bridge) { bridge_ = bridge; }
  // Answers bridge specials with SpecialError UNIMPLEMENTED (a host-side
  // stand-in that knows it is no simulation).
  void set_refuse_specials(bool refuse) { refuse_specials_ = refuse; }
  // When false, the peer stops reading (its side's buffers fill up).
  void set_reading(bool reading) { reading_ = reading; }

  // Serves `fd` (owned from now on) until StopServing.
  void StartServing(int fd) {
    StopServing();
    {
      std::lock_guard<std::mutex> lock(mutex_);
      fd_ = fd;
    }
    stop_ = false;
    thread_ = std::thread([this, fd] { ServeLoop(fd); });
  }

  // Stops the thread and closes the descriptor.
  void StopServing() {
    stop_ = true;
    if (thread_.joinable()) thread_.join();
    {
      std::lock_guard<std::mutex> write_lock(write_mutex_);
      link_fd_ = -1;
    }
    std::lock_guard<std::mutex> lock(mutex_);
    if (fd_ >= 0) ::close(fd_);
    fd_ = -1;
  }

  // Writes raw bytes to the backend (any thread; false before a TCP
  // connection was accepted or after the link went away).
  bool Write(const std::vector<uint8_t>& bytes) {
    std::lock_guard<std::mutex> write_lock(write_mutex_);
    const int fd = link_fd_;
    return fd >= 0 && WriteAll(fd, bytes.data(), bytes.size());
  }
  // Waits until the peer has a link to write to (TCP: a connection).
  bool WaitForLink(std::chrono::milliseconds timeout) const {
    const Clock::time_point deadline = Clock::now() + timeout;
    while (link_fd_ < 0 && Clock::now() < deadline) std::this_thread::sleep_for(2ms);
    return link_fd_ >= 0;
  }
  // Writes one frame.
  bool WriteFrame(const snp::Frame& frame) { return Write(snp::EncodeFrame(frame)); }

  // Frames received so far.
  std::vector<snp::Frame> Received() const {
    std::lock_guard<std::mutex> lock(mutex_);
    return received_;
  }
  // Waits until at least `count` frames came.
  bool WaitForFrames(std::size_t count, std::chrono::milliseconds timeout) const {
    const Clock::time_point deadline = Clock::now() + timeout;
    while (Clock::now() < deadline) {
      if (Received().size() >= count) return true;
      std::this_thread::sleep_for(2ms);
    }
    return Received().size() >= count;
  }
  // Hellos (GetSimInfo to the bridge) received so far.
  int Hellos() const {
    int n = 0;
    for (const snp::Frame& f : Received()) n += f.type == snp::MessageType::kGetSimInfo;
    return n;
  }

 protected:
  // Called on the serving thread before reading (TCP accepts here); returns
  // the descriptor to read or -1 to try again.
  virtual int Ready(int fd) { return fd; }

 private:
  void ServeLoop(int fd) {
    snp::FrameDecoder decoder;
    std::vector<uint8_t> buffer(4096);
    while (!stop_) {
      const int link = Ready(fd);
      link_fd_ = link;
      if (link < 0 || !reading_) {
        std::this_thread::sleep_for(5ms);
        continue;
      }
      pollfd p{.fd = link, .events = POLLIN, .revents = 0};
      if (::poll(&p, 1, 20) <= 0) continue;
      const ssize_t n = ::read(link, buffer.data(), buffer.size());
      if (n <= 0) {
        std::this_thread::sleep_for(5ms);  // the backend closed its end
        continue;
      }
      for (const snp::DecodeEvent& event :
           decoder.Feed(std::span<const uint8_t>(buffer.data(), static_cast<std::size_t>(n)))) {
        if (const auto* decoded = std::get_if<snp::DecodedFrame>(&event)) Answer(decoded->frame);
      }
    }
  }

  void Answer(const snp::Frame& frame) {
    {
      std::lock_guard<std::mutex> lock(mutex_);
      received_.push_back(frame);
    }
    if (frame.destination.kind == snp::NodeKind::kBridge) {
      if (refuse_specials_) {
        WriteFrame(snp::MakeFrame(snp::Address::Bridge(), snp::Address::Host(),
                                  snp::SpecialError{.acked = frame.type,
                                                    .code = StatusCode::kUnimplemented,
                                                    .text = "manual assembly required"}));
      } else if (bridge_ && frame.type == snp::MessageType::kGetSimInfo) {
        WriteFrame(snp::MakeFrame(snp::Address::Bridge(), snp::Address::Host(), kSimInfo));
      }
      return;
    }
    if (frame.destination.kind != snp::NodeKind::kModule || frame.destination.IsBroadcast()) {
      return;
    }
    const snp::Address module = frame.destination;
    if (frame.type == snp::MessageType::kReadServoAngle) {
      WriteFrame(snp::MakeFrame(module, snp::Address::Host(), snp::ServoAngle{.angle = 0.25f}));
    } else {
      WriteFrame(snp::MakeFrame(module, snp::Address::Host(),
                                snp::Ack{.acked = frame.type, .status = StatusCode::kOk}));
    }
  }

  std::atomic<bool> bridge_{false};
  std::atomic<bool> refuse_specials_{false};
  std::atomic<bool> reading_{true};
  std::atomic<bool> stop_{false};
  std::atomic<int> link_fd_{-1};  // where Write goes: the pty master or the connection
  std::thread thread_;
  mutable std::mutex mutex_;
  std::mutex write_mutex_;
  int fd_ = -1;                       // guarded by mutex_
  std::vector<snp::Frame> received_;  // guarded by mutex_
};

// A robot on a pty: the backend opens `Device()`, a symlink to the slave.
class PtyPeer : public PeerCore {
 public:
  PtyPeer() {
    char dir_template[] = "/tmp/yamor_serial_test_XXXXXX";
    const char* dir = ::mkdtemp(dir_template);
    EXPECT_NE(dir, nullptr);
    dir_ = dir ? dir : "/tmp";
    link_ = dir_ + "/robot";
    Start();
  }
  ~PtyPeer() override {
    Stop();
    std::filesystem::remove_all(dir_);
  }

  // The device path handed to the backend.
  std::string Device() const { return link_; }

  // Opens a new pty and points the symlink at its slave.
  void Start() {
    const int master = ::posix_openpt(O_RDWR | O_NOCTTY | O_CLOEXEC);
    ASSERT_GE(master, 0) << std::strerror(errno);
    ASSERT_EQ(::grantpt(master), 0);
    ASSERT_EQ(::unlockpt(master), 0);
    char name[256];
    ASSERT_EQ(::ptsname_r(master, name, sizeof name), 0);
    // Our own slave descriptor in raw mode, as yamor-bridge keeps one.
    slave_fd_ = ::open(name, O_RDWR | O_NOCTTY | O_CLOEXEC);
    ASSERT_GE(slave_fd_, 0) << std::strerror(errno);
    termios t{};
    ASSERT_EQ(::tcgetattr(slave_fd_, &t), 0);
    ::cfmakeraw(&t);
    ASSERT_EQ(::tcsetattr(slave_fd_, TCSANOW, &t), 0);
    std::filesystem::remove(link_);
    std::filesystem::create_symlink(name, link_);
    StartServing(master);
  }

  // Closes the pty (the backend's reads fail) and removes the symlink.
  void Stop() {
    StopServing();
    if (slave_fd_ >= 0) ::close(slave_fd_);
    slave_fd_ = -1;
    std::filesystem::remove(link_);
  }

 private:
  std::string dir_;
  std::string link_;
  int slave_fd_ = -1;
};

// A robot behind a TCP listener on 127.0.0.1 (ephemeral port, kept across
// restarts); serves the first connection.
class TcpPeer : public PeerCore {
 public:
  TcpPeer() { Start(); }
  ~TcpPeer() override { Stop(); }

  // The device address handed to the backend.
  std::string Device() const { return "tcp://127.0.0.1:" + std::to_string(port_); }

  // Listens (again, on the same port).
  void Start() {
    const int listener = ::socket(AF_INET, SOCK_STREAM | SOCK_CLOEXEC, 0);
    ASSERT_GE(listener, 0);
    const int one = 1;
    ::setsockopt(listener, SOL_SOCKET, SO_REUSEADDR, &one, sizeof one);
    sockaddr_in address{};
    address.sin_family = AF_INET;
    address.sin_port = htons(port_);
    address.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    ASSERT_EQ(::bind(listener, reinterpret_cast<sockaddr*>(&address), sizeof address), 0)
        << std::strerror(errno);
    ASSERT_EQ(::listen(listener, 4), 0);
    socklen_t size = sizeof address;
    ASSERT_EQ(::getsockname(listener, reinterpret_cast<sockaddr*>(&address), &size), 0);
    port_ = ntohs(address.sin_port);
    StartServing(listener);
  }

  // Closes the connection and the listener.
  void Stop() {
    StopServing();  // closes the listener (the served descriptor)
    if (connection_ >= 0) ::close(connection_);
    connection_ = -1;
  }

 protected:
  int Ready(int listener) override {
    if (connection_ >= 0) return connection_;
    pollfd p{.fd = listener, .events = POLLIN, .revents = 0};
    if (::poll(&p, 1, 20) <= 0) return -1;
    connection_ = ::accept4(listener, nullptr, nullptr, SOCK_CLOEXEC);
    if (connection_ >= 0) {
      const int one = 1;  // as yamor-bridge: small frames go at once
      ::setsockopt(connection_, IPPROTO_TCP, TCP_NODELAY, &one, sizeof one);
    }
    return connection_;
  }

 private:
  uint16_t port_ = 0;
  int connection_ = -1;  // serving thread only, and Stop after the join
};

enum class Transport { kPty, kTcp };

std::string TransportName(const ::testing::TestParamInfo<Transport>& info) {
  return info.param == Transport::kPty ? "Pty" : "Tcp";
}

snp::Frame FromModule(uint8_t id, const snp::Message& message) {
  return snp::MakeFrame(snp::Address::Module(id), snp::Address::Host(), message);
}

snp::Frame ToModule(uint8_t id, const snp::Message& message) {
  return snp::MakeFrame(snp::Address::Host(), snp::Address::Module(id), message);
}

// Runs `f` and returns the yamor::Error it throws (fails the test if none).
template <typename F>
Error ErrorOf(F&& f) {
  try {
    f();
  } catch (const Error& e) {
    return e;
  }
  ADD_FAILURE() << "no yamor::Error thrown";
  return Error(StatusCode::kOk, "");
}

class SerialBackendTest : public ::testing::TestWithParam<Transport> {
 protected:
  void SetUp() override {
    if (GetParam() == Transport::kPty) {
      pty_ = std::make_unique<PtyPeer>();
    } else {
      tcp_ = std::make_unique<TcpPeer>();
    }
  }

  PeerCore& peer() { return pty_ ? static_cast<PeerCore&>(*pty_) : *tcp_; }
  std::string Device() const { return pty_ ? pty_->Device() : tcp_->Device(); }
  void StopPeer() {
    if (pty_) {
      pty_->Stop();
    } else {
      tcp_->Stop();
    }
  }
  void RestartPeer() {
    if (pty_) {
      pty_->Start();
    } else {
      tcp_->Start();
    }
  }
  // Options for the peer's device. A silent peer costs `hello_timeout` per
  // open; where a test expects an answer, give a loaded machine time (the
  // answer ends the wait at once).
  SerialOptions Options(double hello_timeout = 0.2) const {
    SerialOptions options;
    options.device = Device();
    options.hello_timeout = hello_timeout;
    return options;
  }

  std::unique_ptr<PtyPeer> pty_;
  std::unique_ptr<TcpPeer> tcp_;
};

TEST_P(SerialBackendTest, FramesRoundTripBothWays) {
  SerialBackend backend(Options());
  EXPECT_EQ(backend.Name(), GetParam() == Transport::kPty ? "serial" : "tcp");
  EXPECT_EQ(backend.device(), Device());
  EXPECT_TRUE(backend.IsOpen());

  const snp::Frame request = ToModule(3, snp::ReadServoAngle{});
  backend.Send(request);
  const std::optional<snp::Frame> reply = backend.Receive(2s);
  ASSERT_TRUE(reply.has_value());
  EXPECT_EQ(*reply, FromModule(3, snp::ServoAngle{.angle = 0.25f}));

  // A frame the robot sends on its own.
  ASSERT_TRUE(peer().WaitForLink(2s));
  snp::Accelerometer accelerometer;
  accelerometer.samples = {{.x = 1, .y = 2, .z = 3}, {.x = 512, .y = 511, .z = 760}};
  const snp::Frame event = FromModule(5, accelerometer);
  ASSERT_TRUE(peer().WriteFrame(event));
  const std::optional<snp::Frame> received = backend.Receive(2s);
  ASSERT_TRUE(received.has_value());
  EXPECT_EQ(*received, event);

  const std::vector<snp::Frame> sent = peer().Received();
  ASSERT_EQ(sent.size(), 2u);
  EXPECT_EQ(sent[0], snp::MakeFrame(snp::Address::Host(), snp::Address::Bridge(),
                                    snp::GetSimInfo{}));
  EXPECT_EQ(sent[1], request);
  // The hello's bytes as docs/snp.md ("The hello") shows them.
  EXPECT_EQ(snp::EncodeFrame(sent[0]),
            (std::vector<uint8_t>{0xA5, 0x00, 0x09, 0x00, 0x00, 0x4E, 0x71, 0x4B}));

  const SerialStats stats = backend.stats();
  EXPECT_EQ(stats.frames_out, 2u);  // hello + request
  EXPECT_EQ(stats.bytes_out, 16u);  // two empty-payload frames
  EXPECT_EQ(stats.frames_in, 2u);
  EXPECT_EQ(stats.bytes_in, snp::EncodeFrame(*reply).size() + snp::EncodeFrame(event).size());
  EXPECT_EQ(stats.skipped_bytes, 0u);
  EXPECT_EQ(stats.decode_errors, 0u);
  EXPECT_EQ(stats.reconnects, 0u);
}

TEST_P(SerialBackendTest, ManyRequestsInARowEachGetTheirAnswerInOrder) {
  SerialBackend backend(Options());
  constexpr int kRequests = 500;
  // Bursts of 10 requests, then their 10 answers: the answers queue up in the
  // OS buffers and the inbox meanwhile.
  for (int burst = 0; burst < kRequests / 10; ++burst) {
    for (int i = 0; i < 10; ++i) {
      const auto id = static_cast<uint8_t>((burst * 10 + i) % 255);
      backend.Send(ToModule(id, snp::SetLimits{.min_angle = -0.5f, .max_angle = 0.5f}));
    }
    for (int i = 0; i < 10; ++i) {
      const auto id = static_cast<uint8_t>((burst * 10 + i) % 255);
      const std::optional<snp::Frame> reply = backend.Receive(5s);
      ASSERT_TRUE(reply.has_value()) << "request " << burst * 10 + i;
      EXPECT_EQ(*reply, FromModule(id, snp::Ack{.acked = snp::MessageType::kSetLimits,
                                                .status = StatusCode::kOk}));
    }
  }
  const SerialStats stats = backend.stats();
  EXPECT_EQ(stats.frames_out, kRequests + 1u);
  EXPECT_EQ(stats.frames_in, static_cast<uint64_t>(kRequests));
  EXPECT_EQ(stats.skipped_bytes, 0u);
}

TEST_P(SerialBackendTest, BridgeCommandsToARealRobotAreRefusedLocally) {
  SerialBackend backend(Options());
  ASSERT_FALSE(backend.IsSimulation());
  backend.Send(snp::MakeFrame(snp::Address::Host(), snp::Address::Bridge(),
                              snp::Step{.duration = 0.01}));
  const std::optional<snp::Frame> reply = backend.Receive(1s);
  ASSERT_TRUE(reply.has_value());
  const auto error = std::get<snp::SpecialError>(snp::DecodeMessage(*reply));
  EXPECT_EQ(error.acked, snp::MessageType::kStep);
  EXPECT_EQ(error.code, StatusCode::kUnimplemented);
  EXPECT_THAT(error.text, HasSubstr("manual assembly required"));
  // Module messages still go out; the Step never did.
  backend.Send(ToModule(2, snp::ReadServoAngle{}));
  ASSERT_TRUE(backend.Receive(2s).has_value());
  ASSERT_TRUE(peer().WaitForFrames(2, 1s));
  const std::vector<snp::Frame> sent = peer().Received();
  ASSERT_EQ(sent.size(), 2u);
  EXPECT_EQ(sent[0].type, snp::MessageType::kGetSimInfo);
  EXPECT_EQ(sent[1].type, snp::MessageType::kReadServoAngle);
  EXPECT_EQ(backend.stats().frames_out, 2u);
}

TEST_P(SerialBackendTest, HelloAnsweredWithSimInfoMeansABridge) {
  peer().set_bridge(true);
  SerialBackend backend(Options(/*hello_timeout=*/3.0));
  EXPECT_TRUE(backend.IsSimulation());
  ASSERT_TRUE(backend.sim_info().has_value());
  EXPECT_EQ(*backend.sim_info(), kSimInfo);
  EXPECT_EQ(peer().Hellos(), 1);
  // The SimInfo was the hello's answer, not a frame for Receive.
  EXPECT_FALSE(backend.Receive(50ms).has_value());
  EXPECT_EQ(backend.stats().frames_in, 1u);
}

TEST_P(SerialBackendTest, SilenceAfterTheHelloMeansARealRobot) {
  const Clock::time_point start = Clock::now();
  SerialBackend backend(Options());
  const double elapsed = SecondsSince(start);
  EXPECT_FALSE(backend.IsSimulation());
  EXPECT_FALSE(backend.sim_info().has_value());
  EXPECT_GE(elapsed, 0.2);  // waited the whole hello_timeout
  EXPECT_LT(elapsed, 1.5);
  ASSERT_TRUE(peer().WaitForFrames(1, 1s));
  EXPECT_EQ(peer().Hellos(), 1);
}

TEST_P(SerialBackendTest, HelloRefusedWithSpecialErrorMeansNoSimulationWithoutWaiting) {
  peer().set_refuse_specials(true);
  const Clock::time_point start = Clock::now();
  SerialBackend backend(Options(/*hello_timeout=*/5.0));
  EXPECT_LT(SecondsSince(start), 4.0) << "the refusal ends the wait";
  EXPECT_FALSE(backend.IsSimulation());
  EXPECT_FALSE(backend.Receive(50ms).has_value()) << "the refusal was the hello's answer";
}

TEST_P(SerialBackendTest, GarbageBeforeAndBetweenFramesIsSkippedAndCountedExactly) {
  SerialBackend backend(Options());
  std::mt19937 random(20261202);
  std::uniform_int_distribution<int> byte(0, 255);
  // 10 MB in all, as the link-fault test asks.
  std::vector<uint8_t> garbage_a(5'000'000), garbage_b(5'000'000 + 77);
  for (uint8_t& b : garbage_a) b = static_cast<uint8_t>(byte(random));
  for (uint8_t& b : garbage_b) b = static_cast<uint8_t>(byte(random));
  const snp::Frame first = FromModule(1, snp::ServoAngle{.angle = -0.5f});
  const snp::Frame second = FromModule(2, snp::Ack{.acked = snp::MessageType::kSetLimits,
                                                   .status = StatusCode::kOutOfRange});
  std::vector<uint8_t> stream = garbage_a;
  snp::AppendEncodedFrame(first, stream);
  stream.insert(stream.end(), garbage_b.begin(), garbage_b.end());
  snp::AppendEncodedFrame(second, stream);

  // The seed's garbage hides no frame of its own (else pick another seed).
  snp::FrameDecoder reference;
  int reference_frames = 0;
  for (const snp::DecodeEvent& e : reference.Feed(stream)) {
    reference_frames += std::holds_alternative<snp::DecodedFrame>(e);
  }
  ASSERT_EQ(reference_frames, 2);
  ASSERT_EQ(reference.stats().skipped_bytes, garbage_a.size() + garbage_b.size());
  ASSERT_GT(reference.stats().TotalErrors(), 0u);

  ASSERT_TRUE(peer().WaitForLink(2s));
  std::thread writer([&] { EXPECT_TRUE(peer().Write(stream)); });
  const std::optional<snp::Frame> got_first = backend.Receive(20s);
  const std::optional<snp::Frame> got_second = backend.Receive(20s);
  writer.join();
  ASSERT_TRUE(got_first.has_value());
  ASSERT_TRUE(got_second.has_value());
  EXPECT_EQ(*got_first, first);
  EXPECT_EQ(*got_second, second);

  const SerialStats stats = backend.stats();
  EXPECT_EQ(stats.bytes_in, stream.size());
  EXPECT_EQ(stats.frames_in, 2u);
  EXPECT_EQ(stats.skipped_bytes, garbage_a.size() + garbage_b.size());
  EXPECT_EQ(stats.decode_errors, reference.stats().TotalErrors());
}

TEST_P(SerialBackendTest, FramesSplitByteByByteAreReassembled) {
  SerialBackend backend(Options());
  const snp::Frame first = FromModule(7, snp::ServoAngle{.angle = 1.0f});
  const snp::Frame second = FromModule(8, snp::Ack{.acked = snp::MessageType::kControl,
                                                   .status = StatusCode::kOk});
  std::vector<uint8_t> stream = snp::EncodeFrame(first);
  snp::AppendEncodedFrame(second, stream);
  ASSERT_TRUE(peer().WaitForLink(2s));
  std::thread writer([&] {
    for (uint8_t b : stream) {
      EXPECT_TRUE(peer().Write({b}));
      std::this_thread::sleep_for(1ms);
    }
  });
  const std::optional<snp::Frame> got_first = backend.Receive(5s);
  const std::optional<snp::Frame> got_second = backend.Receive(5s);
  writer.join();
  ASSERT_TRUE(got_first.has_value());
  ASSERT_TRUE(got_second.has_value());
  EXPECT_EQ(*got_first, first);
  EXPECT_EQ(*got_second, second);
  EXPECT_EQ(backend.stats().skipped_bytes, 0u);
}

TEST_P(SerialBackendTest, ReceiveReturnsWithinItsTimeoutWhenNothingComes) {
  SerialBackend backend(Options());
  const Clock::time_point start = Clock::now();
  EXPECT_FALSE(backend.Receive(150ms).has_value());
  const double elapsed = SecondsSince(start);
  EXPECT_GE(elapsed, 0.14);
  EXPECT_LT(elapsed, 0.8);
  EXPECT_FALSE(backend.Receive(0ms).has_value());
}

TEST_P(SerialBackendTest, PeerClosingIsUnavailableAndTheNextSendReopens) {
  SerialBackend backend(Options(/*hello_timeout=*/1.0));
  ASSERT_FALSE(backend.IsSimulation());
  EXPECT_EQ(backend.Generation(), 1u);
  ASSERT_TRUE(peer().WaitForLink(2s));
  StopPeer();

  const Clock::time_point start = Clock::now();
  const Error lost = ErrorOf([&] { backend.Receive(3s); });
  EXPECT_LT(SecondsSince(start), 2.0);  // noticed at once, not at the timeout
  EXPECT_EQ(lost.code(), StatusCode::kUnavailable);
  EXPECT_THAT(lost.what(), HasSubstr(Device()));
  EXPECT_FALSE(backend.IsOpen());
  // Later calls keep failing while the peer is away.
  EXPECT_EQ(ErrorOf([&] { backend.Receive(10ms); }).code(), StatusCode::kUnavailable);
  const Error reopen_failed = ErrorOf([&] { backend.Send(ToModule(4, snp::ReadServoAngle{})); });
  EXPECT_EQ(reopen_failed.code(), StatusCode::kUnavailable);
  EXPECT_THAT(reopen_failed.what(), HasSubstr(Device()));

  // The peer comes back, now as a bridge: the next Send reopens and says hello.
  peer().set_bridge(true);
  RestartPeer();
  backend.Send(ToModule(4, snp::ReadServoAngle{}));
  EXPECT_TRUE(backend.IsOpen());
  EXPECT_TRUE(backend.IsSimulation());
  const std::optional<snp::Frame> reply = backend.Receive(2s);
  ASSERT_TRUE(reply.has_value());
  EXPECT_EQ(*reply, FromModule(4, snp::ServoAngle{.angle = 0.25f}));
  EXPECT_EQ(peer().Hellos(), 2);  // the first link's and the reopened one's
  EXPECT_EQ(backend.stats().reconnects, 1u);
  EXPECT_EQ(backend.Generation(), 2u) << "the driver relinks a reopened robot";
}

INSTANTIATE_TEST_SUITE_P(Transports, SerialBackendTest,
                         ::testing::Values(Transport::kPty, Transport::kTcp), TransportName);

TEST(SerialBackendPty, PeerThatStopsReadingStallsSendIntoUnavailable) {
  PtyPeer peer;
  SerialOptions options;
  options.device = peer.Device();
  options.hello_timeout = 0.1;
  options.write_timeout = 0.2;
  SerialBackend backend(options);
  peer.set_reading(false);
  const snp::Frame frame = ToModule(3, snp::SetLimits{.min_angle = -1.0f, .max_angle = 1.0f});
  const Clock::time_point start = Clock::now();
  std::optional<Error> error;
  for (int i = 0; i < 100000 && !error; ++i) {
    try {
      backend.Send(frame);
    } catch (const Error& e) {
      error = e;
    }
  }
  ASSERT_TRUE(error.has_value()) << "the pty never filled up";
  EXPECT_EQ(error->code(), StatusCode::kUnavailable);
  EXPECT_THAT(error->what(), HasSubstr(peer.Device()));
  EXPECT_THAT(error->what(), HasSubstr("stalled"));
  EXPECT_LT(SecondsSince(start), 10.0);
}

TEST(SerialBackendOpen, MissingDeviceIsUnavailableNamingThePath) {
  SerialOptions options;
  options.device = "/nonexistent/yamor/ttyUSB9";
  const Error e = ErrorOf([&] { SerialBackend backend(options); });
  EXPECT_EQ(e.code(), StatusCode::kUnavailable);
  EXPECT_THAT(e.what(), HasSubstr("/nonexistent/yamor/ttyUSB9"));
  EXPECT_THAT(e.what(), HasSubstr("No such file"));
}

TEST(SerialBackendOpen, RefusedTcpConnectionIsUnavailableNamingTheAddress) {
  // A port that was free a moment ago and has no listener.
  const int s = ::socket(AF_INET, SOCK_STREAM, 0);
  ASSERT_GE(s, 0);
  sockaddr_in address{};
  address.sin_family = AF_INET;
  address.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  ASSERT_EQ(::bind(s, reinterpret_cast<sockaddr*>(&address), sizeof address), 0);
  socklen_t size = sizeof address;
  ASSERT_EQ(::getsockname(s, reinterpret_cast<sockaddr*>(&address), &size), 0);
  ::close(s);
  SerialOptions options;
  options.device = "tcp://127.0.0.1:" + std::to_string(ntohs(address.sin_port));
  const Error e = ErrorOf([&] { SerialBackend backend(options); });
  EXPECT_EQ(e.code(), StatusCode::kUnavailable);
  EXPECT_THAT(e.what(), HasSubstr(options.device));
}

TEST(SerialBackendOpen, NonTerminalDeviceIsUnavailable) {
  SerialOptions options;
  options.device = "/dev/null";  // opens, but cannot be waited on
  const Error e = ErrorOf([&] { SerialBackend backend(options); });
  EXPECT_EQ(e.code(), StatusCode::kUnavailable);
  EXPECT_THAT(e.what(), HasSubstr("/dev/null"));
}

TEST(SerialOptionsTest, BadValuesAreRejectedNamingKeyAndValue) {
  auto code_of = [](SerialOptions o) {
    o.device = o.device.empty() ? "/dev/ttyUSB0" : o.device;
    return ErrorOf([&] { ValidateSerialOptions(o); });
  };
  SerialOptions o;
  o.baud = 12345;
  Error e = code_of(o);
  EXPECT_EQ(e.code(), StatusCode::kOutOfRange);
  EXPECT_THAT(e.what(), HasSubstr("baud 12345"));
  o = {};
  o.data_bits = 9;
  e = code_of(o);
  EXPECT_EQ(e.code(), StatusCode::kOutOfRange);
  EXPECT_THAT(e.what(), HasSubstr("data_bits 9"));
  o = {};
  o.stop_bits = 3;
  EXPECT_THAT(code_of(o).what(), HasSubstr("stop_bits 3"));
  o = {};
  o.hello_timeout = -1.0;
  EXPECT_EQ(code_of(o).code(), StatusCode::kOutOfRange);
  o = {};
  o.device = "tcp://localhost";
  e = code_of(o);
  EXPECT_EQ(e.code(), StatusCode::kInvalidArgument);
  EXPECT_THAT(e.what(), HasSubstr("tcp://localhost"));
  o.device = "tcp://localhost:99999";
  EXPECT_THAT(code_of(o).what(), HasSubstr("99999"));
  EXPECT_EQ(ErrorOf([] { ParseParity("mark"); }).code(), StatusCode::kInvalidArgument);
  EXPECT_THAT(ErrorOf([] { ParseFlowControl("rts"); }).what(), HasSubstr("'rts'"));
  EXPECT_EQ(ParseParity("even"), Parity::kEven);
  EXPECT_EQ(ParseFlowControl("hardware"), FlowControl::kHardware);
  EXPECT_EQ(FlowControlName(FlowControl::kSoftware), "software");
  EXPECT_TRUE(IsSupportedBaudRate(115200));
  EXPECT_FALSE(IsSupportedBaudRate(0));
  SerialOptions good;
  good.device = "tcp://[::1]:2223";
  EXPECT_NO_THROW(ValidateSerialOptions(good));
}

TEST(SerialBackendPty, LineSettingsAreAppliedInRawMode) {
  PtyPeer peer;
  SerialOptions options;
  options.device = peer.Device();
  options.hello_timeout = 0.05;
  options.baud = 57600;
  options.data_bits = 7;
  options.parity = Parity::kEven;
  options.stop_bits = 2;
  options.flow_control = FlowControl::kHardware;  // a pty may refuse: not an error
  SerialBackend backend(options);
  const int fd = ::open(peer.Device().c_str(), O_RDWR | O_NOCTTY | O_CLOEXEC);
  ASSERT_GE(fd, 0);
  termios t{};
  ASSERT_EQ(::tcgetattr(fd, &t), 0);
  ::close(fd);
  EXPECT_EQ(::cfgetospeed(&t), B57600);
  EXPECT_TRUE(t.c_cflag & CSTOPB);
  // Linux's pty driver always keeps CS8 without parity (pty_set_termios), so
  // data bits and parity cannot be seen here; a real UART takes them.
  EXPECT_FALSE(t.c_lflag & (ICANON | ECHO | ISIG));  // raw
  EXPECT_FALSE(t.c_oflag & OPOST);
}

}  // namespace
}  // namespace yamor::host
