// ParseHosts: --hosts lists and @FILE host files.
#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <string>

#include "common/status.h"
#include "optimizer-plugins/framework/host_pool.h"

namespace yamor::optimizer {
namespace {

// The error ParseHosts throws for `spec` (fails the test if none).
Error ParseError(const std::string& spec) {
  try {
    ParseHosts(spec);
  } catch (const Error& e) {
    return e;
  }
  ADD_FAILURE() << "no error for '" << spec << "'";
  return Error(StatusCode::kOk, "");
}

// A temporary file removed at the end of the test.
class TempFile {
 public:
  explicit TempFile(const std::string& text) {
    const std::string name =
        "yamor_hosts_" + std::to_string(getpid()) + "_" + std::to_string(counter_++) + ".txt";
    path_ = (std::filesystem::temp_directory_path() / name).string();
    std::ofstream(path_) << text;
  }
  ~TempFile() { std::filesystem::remove(path_); }
  const std::string& path() const { return path_; }

 private:
  static inline int counter_ = 0;
  std::string path_;
};

TEST(ParseHostsTest, CommaSeparatedList) {
  const std::vector<HostAddress> hosts = ParseHosts("localhost:2224, 10.0.0.7:2300,[::1]:9");
  ASSERT_EQ(hosts.size(), 3u);
  EXPECT_EQ(hosts[0].host, "localhost");
  EXPECT_EQ(hosts[0].port, 2224);
  EXPECT_EQ(hosts[1].host, "10.0.0.7");
  EXPECT_EQ(hosts[1].port, 2300);
  EXPECT_EQ(hosts[2].host, "::1");
  EXPECT_EQ(hosts[2].port, 9);
  EXPECT_EQ(hosts[0].ToString(), "localhost:2224");
  EXPECT_EQ(hosts[2].ToString(), "[::1]:9");
  EXPECT_EQ(ParseHosts("h:65535").at(0).port, 65535);
}

TEST(ParseHostsTest, BadEntriesAreNamed) {
  struct Case {
    std::string spec;
    std::string expected;  // substring of the message
  };
  const Case cases[] = {
      {"", "empty host list"},
      {"  ", "empty host list"},
      {"a:1,,b:2", "entry 2"},
      {"a:1,", "entry 2"},
      {"a:1,hostonly", "'hostonly'"},
      {"a:0", "'a:0': port"},
      {"a:65536", "'a:65536': port"},
      {"a:12x", "'a:12x': port"},
      {"a:", "'a:': port"},
      {":80", "empty host"},
      {"::1:80", "[ADDRESS]:PORT"},
      {"[::1]80", "[IPV6-ADDRESS]:PORT"},
      {"a b:1", "invalid host"},
      {"a:1,b:2,a:1", "entry 3: duplicate host a:1 (also host list entry 1)"},
      {"@", "missing file name"},
  };
  for (const Case& c : cases) {
    const Error e = ParseError(c.spec);
    EXPECT_EQ(e.code(), StatusCode::kInvalidArgument) << c.spec;
    EXPECT_NE(std::string(e.what()).find(c.expected), std::string::npos)
        << "'" << c.spec << "' -> " << e.what();
  }
}

TEST(ParseHostsTest, HostFileWithCommentsAndBlankLines) {
  TempFile file(
      "# the lab machines\n"
      "\n"
      "pc-1:2224   # fast one\n"
      "  pc-2:2225\n"
      "\t\n"
      "[fe80::1]:2224\n");
  const std::vector<HostAddress> hosts = ParseHosts("@" + file.path());
  ASSERT_EQ(hosts.size(), 3u);
  EXPECT_EQ(hosts[0].ToString(), "pc-1:2224");
  EXPECT_EQ(hosts[1].ToString(), "pc-2:2225");
  EXPECT_EQ(hosts[2].host, "fe80::1");
}

TEST(ParseHostsTest, HostFileErrorsNameFileAndLine) {
  {
    TempFile file("# header\npc-1:2224\n\npc-2\n");
    const Error e = ParseError("@" + file.path());
    EXPECT_EQ(e.code(), StatusCode::kInvalidArgument);
    EXPECT_NE(std::string(e.what()).find(file.path() + ":4: 'pc-2'"), std::string::npos)
        << e.what();
  }
  {
    TempFile file("pc-1:2224\npc-1:2224\n");
    const Error e = ParseError("@" + file.path());
    EXPECT_NE(std::string(e.what()).find(file.path() + ":2: duplicate host pc-1:2224"),
              std::string::npos)
        << e.what();
  }
  {
    TempFile file("# nothing here\n\n");
    const Error e = ParseError("@" + file.path());
    EXPECT_EQ(e.code(), StatusCode::kInvalidArgument);
    EXPECT_NE(std::string(e.what()).find("lists no hosts"), std::string::npos) << e.what();
  }
  const Error missing = ParseError("@/nonexistent/yamor-hosts.txt");
  EXPECT_EQ(missing.code(), StatusCode::kNotFound);
  EXPECT_NE(std::string(missing.what()).find("/nonexistent/yamor-hosts.txt"), std::string::npos);
}

}  // namespace
}  // namespace yamor::optimizer
