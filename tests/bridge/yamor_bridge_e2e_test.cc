// End to end: the real yamor-bridge binary on a pty and on TCP, spoken to
// with SNP frames from proto/snp's encoder.
#include <arpa/inet.h>
#include <fcntl.h>
#include <netinet/in.h>
#include <netinet/tcp.h>
#include <poll.h>
#include <signal.h>
#include <sys/socket.h>
#include <sys/wait.h>
#include <termios.h>
#include <unistd.h>

#include <gtest/gtest.h>

#include <chrono>
#include <cmath>
#include <optional>
#include <random>
#include <stdexcept>
#include <string>
#include <thread>
#include <vector>

#include "physics/morphology.h"
#include "proto/snp/snp.h"

namespace yamor::bridge {
namespace {

using snp::Address;
using Clock = std::chrono::steady_clock;

const std::string kBridge = YAMOR_BRIDGE_PATH;
const std::string kSourceDir = YAMOR_SOURCE_DIR;

int QuadrupedMaster() {
  return physics::Morphology::LoadFile(kSourceDir + "/configs/worlds/quadruped.xml").central();
}

// yamor-bridge as a child process: stdout a pipe (for its endpoint line),
// stderr the test's; SIGKILLed and reaped when the object dies.
class BridgeProcess {
 public:
  explicit BridgeProcess(std::vector<std::string> args) {
    args.insert(args.begin(), kBridge);
    std::vector<char*> argv;
    for (std::string& a : args) argv.push_back(a.data());
    argv.push_back(nullptr);
    int fds[2];
    if (pipe(fds) != 0) throw std::runtime_error("pipe failed");
    pid_ = fork();
    if (pid_ == 0) {
      dup2(fds[1], STDOUT_FILENO);
      close(fds[0]);
      close(fds[1]);
      execv(kBridge.c_str(), argv.data());
      _exit(127);
    }
    close(fds[1]);
    out_ = fds[0];
  }
  ~BridgeProcess() {
    Kill();
    close(out_);
  }
  BridgeProcess(const BridgeProcess&) = delete;
  BridgeProcess& operator=(const BridgeProcess&) = delete;

  // The first stdout line, "" if none within 30 s.
  std::string ReadLine() {
    std::string line;
    const auto deadline = Clock::now() + std::chrono::seconds(30);
    while (Clock::now() < deadline) {
      pollfd p{out_, POLLIN, 0};
      if (poll(&p, 1, 100) <= 0) continue;
      char c = 0;
      if (read(out_, &c, 1) != 1) break;
      if (c == '\n') return line;
      line.push_back(c);
    }
    return line;
  }

  // Exit status within `timeout`; -1 still running, -2 killed by a signal.
  int WaitForExit(std::chrono::seconds timeout) {
    const auto deadline = Clock::now() + timeout;
    while (Clock::now() < deadline) {
      int status = 0;
      if (waitpid(pid_, &status, WNOHANG) == pid_) {
        pid_ = -1;
        return WIFEXITED(status) ? WEXITSTATUS(status) : -2;
      }
      std::this_thread::sleep_for(std::chrono::milliseconds(10));
    }
    return -1;
  }
  void Signal(int signal) {
    if (pid_ > 0) kill(pid_, signal);
  }
  void Kill() {
    if (pid_ <= 0) return;
    kill(pid_, SIGKILL);
    waitpid(pid_, nullptr, 0);
    pid_ = -1;
  }

 private:
  pid_t pid_ = -1;
  int out_ = -1;
};

// The host side of the line: a file descriptor (pty slave or TCP socket).
class HostLink {
 public:
  explicit HostLink(int fd) : fd_(fd) {}
  ~HostLink() {
    if (fd_ >= 0) close(fd_);
  }
  HostLink(const HostLink&) = delete;
  HostLink& operator=(const HostLink&) = delete;

  static HostLink OpenPty(const std::string& path) {
    const int fd = open(path.c_str(), O_RDWR | O_NOCTTY | O_CLOEXEC);
    if (fd < 0) throw std::runtime_error("cannot open " + path);
    termios t{};
    tcgetattr(fd, &t);
    cfmakeraw(&t);
    tcsetattr(fd, TCSANOW, &t);
    return HostLink(fd);
  }
  static HostLink ConnectTcp(int port) {
    const int fd = socket(AF_INET, SOCK_STREAM | SOCK_CLOEXEC, 0);
    sockaddr_in address{};
    address.sin_family = AF_INET;
    address.sin_port = htons(static_cast<uint16_t>(port));
    address.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    if (connect(fd, reinterpret_cast<sockaddr*>(&address), sizeof address) != 0) {
      close(fd);
      throw std::runtime_error("cannot connect to port " + std::to_string(port));
    }
    const int one = 1;
    setsockopt(fd, IPPROTO_TCP, TCP_NODELAY, &one, sizeof one);
    return HostLink(fd);
  }
  HostLink(HostLink&& other) noexcept : fd_(other.fd_) { other.fd_ = -1; }

  void Write(const std::vector<uint8_t>& bytes) {
    std::size_t at = 0;
    while (at < bytes.size()) {
      const ssize_t n = write(fd_, bytes.data() + at, bytes.size() - at);
      if (n < 0) {
        if (errno == EINTR || errno == EAGAIN) continue;
        throw std::runtime_error("write failed");
      }
      at += static_cast<std::size_t>(n);
    }
  }
  void Send(const snp::Frame& frame) { Write(snp::EncodeFrame(frame)); }

  // The next `count` frames (fewer on timeout).
  std::vector<snp::Frame> Receive(std::size_t count,
                                  std::chrono::milliseconds timeout = std::chrono::seconds(20)) {
    std::vector<snp::Frame> frames;
    const auto deadline = Clock::now() + timeout;
    while (frames.size() < count && Clock::now() < deadline) {
      for (snp::DecodeEvent& e : pending_) {
        if (auto* f = std::get_if<snp::DecodedFrame>(&e)) frames.push_back(f->frame);
      }
      pending_.clear();
      if (frames.size() >= count) break;
      pollfd p{fd_, POLLIN, 0};
      if (poll(&p, 1, 50) <= 0) continue;
      uint8_t buffer[4096];
      const ssize_t n = read(fd_, buffer, sizeof buffer);
      if (n <= 0) break;
      bytes_read_ += static_cast<std::size_t>(n);
      decoder_.Feed(std::span<const uint8_t>(buffer, static_cast<std::size_t>(n)), pending_);
    }
    return frames;
  }
  template <typename T>
  T Expect(const snp::Frame& request) {
    Send(request);
    const std::vector<snp::Frame> replies = Receive(1);
    if (replies.size() != 1) {
      ADD_FAILURE() << "no reply to " << snp::MessageTypeName(request.type);
      return T{};
    }
    const snp::Message message = snp::DecodeMessage(replies[0]);
    if (!std::holds_alternative<T>(message)) {
      ADD_FAILURE() << "got " << snp::MessageTypeName(replies[0].type);
      return T{};
    }
    return std::get<T>(message);
  }
  std::size_t bytes_read() const { return bytes_read_; }

 private:
  int fd_ = -1;
  snp::FrameDecoder decoder_;
  std::vector<snp::DecodeEvent> pending_;
  std::size_t bytes_read_ = 0;
};

snp::Frame ToBridge(const snp::Message& m) {
  return snp::MakeFrame(Address::Host(), Address::Bridge(), m);
}
snp::Frame ToModule(int id, const snp::Message& m) {
  return snp::MakeFrame(Address::Host(), Address::Module(static_cast<uint8_t>(id)), m);
}

// Time, a step, a parameter set/refuse/read round trip on the master.
void TalkToBridge(HostLink& host, double expected_start_time) {
  EXPECT_EQ(host.Expect<snp::SimTime>(ToBridge(snp::GetSimTime{})).seconds, expected_start_time);
  EXPECT_NEAR(host.Expect<snp::StepDone>(ToBridge(snp::Step{.duration = 0.05})).time,
              expected_start_time + 0.05, 1e-9);
  const int master = QuadrupedMaster();
  EXPECT_EQ(host.Expect<snp::Ack>(ToModule(master, snp::SetLimits{-1.0f, 0.5f})),
            (snp::Ack{.acked = snp::MessageType::kSetLimits, .status = StatusCode::kOk}));
  EXPECT_EQ(host.Expect<snp::Ack>(ToModule(master, snp::SetLimits{0.5f, -1.0f})).status,
            StatusCode::kOutOfRange);
  const float angle = host.Expect<snp::ServoAngle>(ToModule(master, snp::ReadServoAngle{})).angle;
  EXPECT_LT(std::abs(angle), 1.6f);
  EXPECT_NEAR(host.Expect<snp::SimTime>(ToBridge(snp::GetSimTime{})).seconds,
              expected_start_time + 0.05, 1e-9);
}

std::string PtyPath(const std::string& line) {
  const std::string prefix = "yamor-bridge: pty ";
  if (line.rfind(prefix, 0) != 0) return "";
  return line.substr(prefix.size());
}

int TcpPort(const std::string& line) {
  const std::string prefix = "yamor-bridge: tcp 127.0.0.1:";
  if (line.rfind(prefix, 0) != 0) return 0;
  return std::stoi(line.substr(prefix.size()));
}

TEST(YamorBridgeE2e, PtyRoundTripsAndSurvivesAHostReopeningTheDevice) {
  const std::string link = ::testing::TempDir() + "yamor_bridge_e2e_pty_" +
                           std::to_string(getpid());
  BridgeProcess bridge({"--pty", "--link", link, "--log-level", "warn"});
  const std::string slave = PtyPath(bridge.ReadLine());
  ASSERT_FALSE(slave.empty());
  EXPECT_EQ(slave.rfind("/dev/pts/", 0), 0u) << slave;
  {
    HostLink host = HostLink::OpenPty(link);  // through the symlink
    TalkToBridge(host, 0.0);
  }
  {
    HostLink host = HostLink::OpenPty(slave);  // closed and reopened: same robot
    TalkToBridge(host, 0.05);
  }
  bridge.Signal(SIGTERM);
  EXPECT_EQ(bridge.WaitForExit(std::chrono::seconds(20)), 0);
  EXPECT_NE(access(link.c_str(), F_OK), 0) << "the --link symlink outlives the bridge";
}

TEST(YamorBridgeE2e, PtyTenMegabytesOfGarbageAndByteByByteFrames) {
  BridgeProcess bridge({"--pty", "--log-level", "warn"});
  const std::string slave = PtyPath(bridge.ReadLine());
  ASSERT_FALSE(slave.empty());
  HostLink host = HostLink::OpenPty(slave);
  std::mt19937_64 rng(7);
  std::uniform_int_distribution<int> byte(0, 255);
  auto garbage = [&](std::size_t n) {
    // A candidate's start byte near the end may claim up to a frame's worth
    // of the bytes after it; trailing zeros (never start bytes) let it complete.
    std::vector<uint8_t> bytes(n + snp::kMaxFrameSize, 0);
    for (std::size_t i = 0; i < n; ++i) bytes[i] = static_cast<uint8_t>(byte(rng));
    return bytes;
  };
  host.Write(garbage(5u << 20));
  EXPECT_EQ(host.Expect<snp::SimTime>(ToBridge(snp::GetSimTime{})).seconds, 0.0);
  host.Write(garbage(5u << 20));
  // Split byte by byte, a write per byte.
  for (uint8_t b : snp::EncodeFrame(ToBridge(snp::Step{.duration = 0.01}))) host.Write({b});
  const std::vector<snp::Frame> replies = host.Receive(1);
  ASSERT_EQ(replies.size(), 1u);
  EXPECT_NEAR(std::get<snp::StepDone>(snp::DecodeMessage(replies[0])).time, 0.01, 1e-9);
  TalkToBridge(host, 0.01);
  bridge.Signal(SIGTERM);
  EXPECT_EQ(bridge.WaitForExit(std::chrono::seconds(20)), 0);
}

TEST(YamorBridgeE2e, TcpEphemeralPortOneHostAtATime) {
  BridgeProcess bridge({"--tcp", "0", "--log-level", "warn"});
  const int port = TcpPort(bridge.ReadLine());
  ASSERT_GT(port, 0);
  {
    std::optional<HostLink> first(HostLink::ConnectTcp(port));
    TalkToBridge(*first, 0.0);
    // A second host waits until the first leaves.
    HostLink second = HostLink::ConnectTcp(port);
    second.Send(ToBridge(snp::GetSimTime{}));
    EXPECT_TRUE(second.Receive(1, std::chrono::milliseconds(300)).empty());
    first.reset();
    const std::vector<snp::Frame> replies = second.Receive(1);
    ASSERT_EQ(replies.size(), 1u);
    EXPECT_NEAR(std::get<snp::SimTime>(snp::DecodeMessage(replies[0])).seconds, 0.05, 1e-9);
  }
  {
    HostLink host = HostLink::ConnectTcp(port);  // reconnect: same robot
    TalkToBridge(host, 0.05);
  }
  bridge.Signal(SIGTERM);
  EXPECT_EQ(bridge.WaitForExit(std::chrono::seconds(20)), 0);
}

TEST(YamorBridgeE2e, PacedRepliesTakeTheLineTime) {
  BridgeProcess bridge({"--tcp", "127.0.0.1:0", "--pace", "--baud", "9600", "--log-level", "warn"});
  const int port = TcpPort(bridge.ReadLine());
  ASSERT_GT(port, 0);
  HostLink host = HostLink::ConnectTcp(port);
  ASSERT_EQ(host.Expect<snp::SimTime>(ToBridge(snp::GetSimTime{})).seconds, 0.0);
  constexpr int kFrames = 40;  // 40 SimTime replies of 16 bytes = 640 bytes
  std::vector<uint8_t> burst;
  for (int i = 0; i < kFrames; ++i) {
    for (uint8_t b : snp::EncodeFrame(ToBridge(snp::GetSimTime{}))) burst.push_back(b);
  }
  const auto start = Clock::now();
  host.Write(burst);
  const std::vector<snp::Frame> replies = host.Receive(kFrames);
  const double elapsed = std::chrono::duration<double>(Clock::now() - start).count();
  ASSERT_EQ(replies.size(), static_cast<std::size_t>(kFrames));
  const double line_time = kFrames * 16 * 10.0 / 9600.0;  // 0.667 s
  EXPECT_GT(elapsed, 0.9 * line_time);
  EXPECT_LT(elapsed, line_time + 2.0);  // a hang guard, not a benchmark
  bridge.Signal(SIGINT);
  EXPECT_EQ(bridge.WaitForExit(std::chrono::seconds(20)), 0);
}

TEST(YamorBridgeE2e, RealTimeFactorFreeRunsTheWorld) {
  BridgeProcess bridge({"--tcp", "0", "--real-time", "1", "--log-level", "warn"});
  const int port = TcpPort(bridge.ReadLine());
  ASSERT_GT(port, 0);
  HostLink host = HostLink::ConnectTcp(port);
  const double t0 = host.Expect<snp::SimTime>(ToBridge(snp::GetSimTime{})).seconds;
  const auto wall0 = Clock::now();
  std::this_thread::sleep_for(std::chrono::milliseconds(500));
  const double t1 = host.Expect<snp::SimTime>(ToBridge(snp::GetSimTime{})).seconds;
  const double wall = std::chrono::duration<double>(Clock::now() - wall0).count();
  // Never ahead of the wall clock; behind it only when the machine cannot
  // step that fast (a loaded CI box), so the lower bound is loose.
  EXPECT_GT(t1 - t0, 0.05 * wall);
  EXPECT_LT(t1 - t0, wall + 0.05);
  bridge.Signal(SIGTERM);
  EXPECT_EQ(bridge.WaitForExit(std::chrono::seconds(20)), 0);
}

TEST(YamorBridgeE2e, BadFlagsExitTwo) {
  for (const std::vector<std::string>& args :
       std::vector<std::vector<std::string>>{{"--no-such-flag"},
                                             {"--baud", "0"},
                                             {"--tcp", "host:notaport"},
                                             {"--pty", "--tcp", "2223"},
                                             {"--real-time", "-1"},
                                             {"--world", "no_such_world"}}) {
    BridgeProcess bridge(args);
    EXPECT_EQ(bridge.WaitForExit(std::chrono::seconds(20)), 2) << args[0];
  }
}

}  // namespace
}  // namespace yamor::bridge
