#include "tools/camapp/camapp_server.h"

#include <utility>  // before Asio: its awaitable.hpp uses std::exchange

#include <array>
#include <atomic>
#include <boost/asio.hpp>
#include <deque>
#include <thread>
#include <vector>

#include "common/log.h"
#include "common/status.h"

namespace yamor::camapp {
namespace asio = boost::asio;
using asio::ip::tcp;
using Clock = std::chrono::steady_clock;

namespace {

// One connected client. Used on the I/O thread only.
struct Client {
  explicit Client(tcp::socket s) : socket(std::move(s)) {}
  tcp::socket socket;
  std::deque<std::string> queue;  // lines with their '\n', front being written
  bool writing = false;
  bool closed = false;
  std::array<char, 256> discard{};  // what a client sends is ignored
  std::string peer;
};

}  // namespace

// Thread-safety: every member is used on the I/O thread only, except
// client_count_ (atomic) and the immutable options and port.
struct CamAppServer::Impl {
  explicit Impl(CamAppServerOptions o) : options(std::move(o)), acceptor(io), timer(io) {}

  void Accept() {
    acceptor.async_accept([this](const boost::system::error_code& ec, tcp::socket socket) {
      if (ec == asio::error::operation_aborted) return;
      if (!ec) {
        auto client = std::make_shared<Client>(std::move(socket));
        boost::system::error_code ignored;
        client->socket.set_option(tcp::no_delay(true), ignored);
        const auto remote = client->socket.remote_endpoint(ignored);
        client->peer = remote.address().to_string() + ":" + std::to_string(remote.port());
        clients.push_back(client);
        client_count = static_cast<int>(clients.size());
        Log().info("camapp: client {} connected", client->peer);
        Send(client, "YAMOR-CAMAPP 1 " + std::to_string(options.width) + " " +
                         std::to_string(options.height) + "\n");
        Discard(client);
      } else {
        Log().warn("camapp: accept: {}", ec.message());
      }
      Accept();
    });
  }

  void Discard(const std::shared_ptr<Client>& client) {
    client->socket.async_read_some(asio::buffer(client->discard),
                                   [this, client](const boost::system::error_code& ec, std::size_t) {
                                     if (ec) return Drop(client, ec == asio::error::eof
                                                                     ? "closed by the client"
                                                                     : ec.message());
                                     Discard(client);
                                   });
  }

  void Send(const std::shared_ptr<Client>& client, std::string line) {
    if (client->closed) return;
    if (client->queue.size() >= options.max_queued_lines) {
      return Drop(client, "more than " + std::to_string(options.max_queued_lines) + " lines unread");
    }
    client->queue.push_back(std::move(line));
    if (!client->writing) Write(client);
  }

  void Write(const std::shared_ptr<Client>& client) {
    client->writing = true;
    asio::async_write(client->socket, asio::buffer(client->queue.front()),
                      [this, client](const boost::system::error_code& ec, std::size_t) {
                        client->writing = false;
                        if (client->closed) return;
                        if (ec) return Drop(client, ec.message());
                        client->queue.pop_front();
                        if (!client->queue.empty()) Write(client);
                      });
  }

  void Drop(const std::shared_ptr<Client>& client, const std::string& why) {
    if (client->closed) return;
    client->closed = true;
    boost::system::error_code ignored;
    client->socket.close(ignored);
    std::erase(clients, client);
    client_count = static_cast<int>(clients.size());
    Log().info("camapp: client {} gone: {}", client->peer, why);
  }

  void Deliver() {
    const auto now = Clock::now();
    while (!pending.empty() && pending.front().first <= now) {
      const std::string line = pending.front().second + "\n";
      pending.pop_front();
      for (const auto& client : std::vector<std::shared_ptr<Client>>(clients)) Send(client, line);
    }
    if (pending.empty()) return;
    timer.expires_at(pending.front().first);
    timer.async_wait([this](const boost::system::error_code& ec) {
      if (!ec) Deliver();
    });
  }

  const CamAppServerOptions options;
  asio::io_context io;
  tcp::acceptor acceptor;
  asio::steady_timer timer;
  std::deque<std::pair<Clock::time_point, std::string>> pending;
  std::vector<std::shared_ptr<Client>> clients;
  std::atomic<int> client_count{0};
  int port = 0;
  std::thread thread;
};

CamAppServer::CamAppServer(CamAppServerOptions options) : impl_(std::make_unique<Impl>(std::move(options))) {
  const auto& o = impl_->options;
  if (o.port < 0 || o.port > 65535 || o.width <= 0 || o.height <= 0) {
    throw Error(StatusCode::kInvalidArgument, "camapp: port " + std::to_string(o.port) + " or image " +
                                                  std::to_string(o.width) + "x" + std::to_string(o.height) +
                                                  " is invalid");
  }
  const std::string where = o.address + ":" + std::to_string(o.port);
  try {
    const tcp::endpoint endpoint(asio::ip::make_address(o.address), static_cast<unsigned short>(o.port));
    impl_->acceptor.open(endpoint.protocol());
    impl_->acceptor.set_option(tcp::acceptor::reuse_address(true));  // restarts reuse the port
    impl_->acceptor.bind(endpoint);
    impl_->acceptor.listen();
  } catch (const boost::system::system_error& e) {
    throw Error(StatusCode::kUnavailable, "camapp: cannot listen on " + where + ": " + e.what());
  }
  impl_->port = impl_->acceptor.local_endpoint().port();
  impl_->Accept();
  impl_->thread = std::thread([impl = impl_.get()] {
    try {
      impl->io.run();
    } catch (const std::exception& e) {
      Log().error("camapp: I/O thread stopped: {}", e.what());
    }
  });
}

CamAppServer::~CamAppServer() {
  asio::post(impl_->io, [impl = impl_.get()] {
    boost::system::error_code ignored;
    impl->acceptor.close(ignored);
    impl->timer.cancel();
    for (const auto& client : std::vector<std::shared_ptr<Client>>(impl->clients)) {
      impl->Drop(client, "server stopping");
    }
    impl->io.stop();
  });
  impl_->thread.join();
}

int CamAppServer::port() const noexcept { return impl_->port; }

int CamAppServer::clients() const { return impl_->client_count.load(); }

void CamAppServer::Publish(std::string line, Clock::time_point send_at) {
  asio::post(impl_->io, [impl = impl_.get(), line = std::move(line), send_at]() mutable {
    const bool idle = impl->pending.empty();
    impl->pending.emplace_back(send_at, std::move(line));
    if (idle) impl->Deliver();
  });
}

}  // namespace yamor::camapp
