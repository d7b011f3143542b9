/// @file view_server.cpp
/// ViewServer on Boost.Beast (HTTP/1.1 and WebSocket over Boost.Asio, Debian's libboost-dev;
/// header-only, Boost.System is header-only since 1.69). The only file of the project that
/// includes Beast: its headers are heavy to compile.
///
/// One io_context run by one thread: every handler runs on it, so the sessions need no strand.
/// What other threads touch is guarded: the client list (clients_mutex: write_frame(),
/// clients() and the I/O thread registering or removing a client) and each client's queue
/// (its own mutex: write_frame() pushes, the I/O thread pops). Each lock is held for a few
/// pointer moves; the I/O thread never writes to a socket with one held.
///
/// The accept loop (I/O thread): a failed accept pauses it on a timer (back_off()), a
/// connection that closes or the timer resumes it (resume_accept()); past max_http_connections
/// an accepted connection closes the HTTP connection waiting longest for its request (admit()).

#include "numen/sim/view/view_server.hpp"

#include <algorithm>
#include <atomic>
#include <boost/asio.hpp>
#include <boost/beast/core.hpp>
#include <boost/beast/http.hpp>
#include <boost/beast/websocket.hpp>
#include <chrono>
#include <cmath>
#include <condition_variable>
#include <deque>
#include <mutex>
#include <nlohmann/json.hpp>
#include <stdexcept>
#include <thread>

#include "input/json_input.hpp"
#include "numen/sim/view/frame_layout_json.hpp"

namespace numen::sim {

namespace asio = boost::asio;
namespace beast = boost::beast;
namespace http = beast::http;
namespace websocket = beast::websocket;
using tcp = asio::ip::tcp;

namespace {

/// Content type of a served file, from its extension.
const char* mime_type(const std::string& path) {
  const auto dot = path.rfind('.');
  const std::string ext = dot == std::string::npos ? "" : path.substr(dot + 1);
  if (ext == "html") return "text/html; charset=utf-8";
  if (ext == "js" || ext == "mjs") return "text/javascript; charset=utf-8";
  if (ext == "css") return "text/css; charset=utf-8";
  if (ext == "json") return "application/json";
  if (ext == "png") return "image/png";
  if (ext == "svg") return "image/svg+xml";
  if (ext == "ico") return "image/x-icon";
  return "application/octet-stream";
}

/// The request target as a relative file path, or empty when it is not one we serve: only
/// [A-Za-z0-9._/-], no "..", no empty segment; "/" and ".../" name index.html.
std::string file_of_target(std::string_view target) {
  std::string t(target.substr(0, target.find('?')));
  if (t.empty() || t.front() != '/') return {};
  if (t.back() == '/') t += "index.html";
  for (const char c : t)
    if (!(std::isalnum(static_cast<unsigned char>(c)) || c == '.' || c == '_' || c == '/' ||
          c == '-'))
      return {};
  if (t.find("..") != std::string::npos || t.find("//") != std::string::npos) return {};
  return t.substr(1);
}

}  // namespace

/// One outgoing WebSocket message: shared by every client it is queued for. Outside the
/// anonymous namespace: WsSession (external linkage) holds a queue of them.
struct Outgoing {
  std::shared_ptr<const std::string> data;
  bool binary = false;  ///< A frame (counted, may be dropped) rather than a text message.
};

ViewHttpAnswer answer_view_http_request(const ViewServerSettings& settings,
                                        std::string_view method, std::string_view target,
                                        bool websocket_upgrade, std::size_t clients) {
  using Kind = ViewHttpAnswer::Kind;
  if (websocket_upgrade) {
    if (target.substr(0, target.find('?')) != settings.stream_path) return {Kind::kNotFound, {}};
    if (clients >= settings.max_clients) return {Kind::kTooManyViewers, {}};
    return {Kind::kUpgrade, {}};
  }
  if (method != "GET" && method != "HEAD") return {Kind::kNotAllowed, {}};
  std::string rel = file_of_target(target);
  if (rel.empty() || settings.static_dir.empty()) return {Kind::kNotFound, {}};
  return {Kind::kFile, std::move(rel)};
}

ViewClientRequest read_view_client_message(std::string_view message, bool text, bool replay,
                                           std::size_t frame_count) {
  using Kind = ViewClientRequest::Kind;
  if (!text) return {Kind::kBad, 0};
  json_input::SyntaxError syntax;  // not reported: the connection is closed and counted
  const auto j = json_input::parse<nlohmann::json>(message, syntax);
  if (j.is_discarded()) return {Kind::kBad, 0};
  if (!replay) return {Kind::kIgnored, 0};
  if (!j.is_object() || j.size() != 1) return {Kind::kBad, 0};
  const auto f = j.find("frame");
  if (f == j.end() || !f->is_number_unsigned()) return {Kind::kBad, 0};
  const std::uint64_t i = f->get<std::uint64_t>();
  if (i >= frame_count) return {Kind::kBad, 0};
  return {Kind::kFrame, i};
}

class WsSession;
class HttpSession;

struct ViewServer::Impl {
  Impl(const ViewServerSettings& s, std::string scene_message, ViewFrameSource* src,
       const std::string& series);

  // The accept loop and the connections' bound (I/O thread).
  void do_accept();
  void back_off();
  void resume_accept();
  void admit(tcp::socket socket);
  void connection_closed();
  void close_all();  // I/O thread
  void add_client(const std::shared_ptr<WsSession>& c);
  void remove_client(const WsSession* c);

  ViewServerSettings settings;
  std::shared_ptr<const std::string> scene, session;
  ViewFrameSource* source = nullptr;
  asio::io_context ioc{1};
  tcp::acceptor acceptor{ioc};
  std::thread thread;
  bool started = false, stopped = false;
  std::uint16_t bound_port = 0;
  std::uint64_t next_id = 1;  // I/O thread
  std::vector<std::weak_ptr<HttpSession>> http_sessions;  // I/O thread, in order of accept
  std::uint64_t next_wait = 1;      // I/O thread: HttpSession::waiting_since()'s clock
  asio::steady_timer backoff{ioc};  // I/O thread: the accept loop's pause
  bool accept_paused = false;       // I/O thread: no accept outstanding, the timer set
  std::uint64_t pause_id = 0;       // I/O thread: the pause the timer's handler belongs to
  int failures_in_a_row = 0;        // I/O thread: accepts failed since the last one accepted
  mutable std::mutex clients_mutex;
  std::condition_variable client_added;             // with clients_mutex: wait_for_client()
  std::vector<std::shared_ptr<WsSession>> clients;  // connected WebSocket clients
  std::atomic<std::uint64_t> connected{0}, total{0}, refused{0}, http_requests{0}, offered{0},
      sent{0}, dropped{0}, bad_input{0}, requests{0}, source_errors{0}, accept_failures{0}, shed{0};
};

/// A WebSocket client: its bounded queue of outgoing messages, its reads of client messages.
class WsSession : public std::enable_shared_from_this<WsSession> {
 public:
  WsSession(ViewServer::Impl& server, tcp::socket&& socket)
      : s_(server), ws_(std::move(socket)) {
    beast::error_code ec;
    const auto ep = beast::get_lowest_layer(ws_).socket().remote_endpoint(ec);
    if (!ec) remote_ = ep.address().to_string() + ":" + std::to_string(ep.port());
  }

  void run(http::request<http::string_body> req) {
    beast::get_lowest_layer(ws_).expires_never();  // the WebSocket's own timeouts from here
    ws_.set_option(websocket::stream_base::timeout::suggested(beast::role_type::server));
    ws_.set_option(websocket::stream_base::decorator(
        [](websocket::response_type& res) { res.set(http::field::server, "numen-view"); }));
    ws_.read_message_max(s_.settings.max_client_message_bytes);
    ws_.async_accept(req, [self = shared_from_this()](beast::error_code ec) {
      if (ec) return self->close(false);
      self->id_ = self->s_.next_id++;
      // The greeting is queued before the client joins the list, so a frame published as soon
      // as it is listed (wait_for_client() returns then) comes after the scene and the session.
      self->enqueue({self->s_.scene, false});
      self->enqueue({self->s_.session, false});
      self->s_.add_client(self);
      self->do_read();
    });
  }

  /// Queues one message (any thread). A frame finding the queue full drops the oldest queued
  /// frame (the one in flight is never dropped).
  void enqueue(Outgoing o) {
    bool kick = false;
    {
      const std::lock_guard<std::mutex> lock(m_);
      if (closed_) return;
      if (o.binary) {
        if (queued_frames_ >= s_.settings.client_queue_frames) {
          const auto it = std::find_if(q_.begin(), q_.end(), [](const Outgoing& x) { return x.binary; });
          q_.erase(it);  // queued_frames_ > 0: there is one
          --queued_frames_;
          dropped_.fetch_add(1, std::memory_order_relaxed);
          s_.dropped.fetch_add(1, std::memory_order_relaxed);
        }
        ++queued_frames_;
      }
      q_.push_back(std::move(o));
      if (!writing_) kick = writing_ = true;
    }
    if (kick) asio::post(ws_.get_executor(), [self = shared_from_this()] { self->do_write(); });
  }

  /// Closes the connection (I/O thread); `bad_input`: counted, and closed with a policy error.
  void close(bool bad_input) {
    {
      const std::lock_guard<std::mutex> lock(m_);
      if (closed_) return;
      closed_ = true;
      q_.clear();
    }
    if (id_ != 0) s_.remove_client(this);
    if (bad_input) {
      s_.bad_input.fetch_add(1, std::memory_order_relaxed);
      ws_.async_close(websocket::close_code::policy_error,
                      [self = shared_from_this()](beast::error_code) { self->hard_close(); });
    } else {
      hard_close();
    }
  }

  void hard_close() {
    beast::error_code ec;
    beast::get_lowest_layer(ws_).socket().shutdown(tcp::socket::shutdown_both, ec);
    beast::get_lowest_layer(ws_).socket().close(ec);
    s_.connection_closed();
  }

  ViewClientCounters counters() const {
    return {id_, remote_, sent_.load(std::memory_order_relaxed),
            dropped_.load(std::memory_order_relaxed)};
  }

 private:
  void do_write() {
    {
      const std::lock_guard<std::mutex> lock(m_);
      if (closed_ || q_.empty()) {
        writing_ = false;
        return;
      }
      current_ = std::move(q_.front());
      q_.pop_front();
      if (current_.binary) --queued_frames_;
    }
    ws_.binary(current_.binary);
    ws_.async_write(asio::buffer(*current_.data),
                    [self = shared_from_this()](beast::error_code ec, std::size_t) {
                      if (ec) return self->close(false);
                      if (self->current_.binary) {
                        self->sent_.fetch_add(1, std::memory_order_relaxed);
                        self->s_.sent.fetch_add(1, std::memory_order_relaxed);
                      }
                      self->current_ = {};
                      self->do_write();
                    });
  }

  void do_read() {
    ws_.async_read(in_, [self = shared_from_this()](beast::error_code ec, std::size_t) {
      if (ec == websocket::error::message_too_big) return self->close(true);
      if (ec) return self->close(false);
      const bool text = self->ws_.got_text();
      const std::string message = beast::buffers_to_string(self->in_.data());
      self->in_.consume(self->in_.size());
      if (!self->on_message(message, text)) return self->close(true);
      self->do_read();
    });
  }

  /// A client message (read_view_client_message()): live, any JSON is ignored; replay,
  /// {"frame": I} asks for frame I. False: bad input.
  bool on_message(const std::string& message, bool text) {
    const ViewClientRequest r = read_view_client_message(
        message, text, s_.source != nullptr, s_.source ? s_.source->frame_count() : 0);
    if (r.kind == ViewClientRequest::Kind::kBad) return false;
    if (r.kind == ViewClientRequest::Kind::kIgnored) return true;
    const std::uint64_t i = r.frame;
    try {
      s_.source->read_frame(static_cast<std::size_t>(i), scratch_);
    } catch (...) {
      s_.source_errors.fetch_add(1, std::memory_order_relaxed);
      return false;
    }
    s_.requests.fetch_add(1, std::memory_order_relaxed);
    enqueue({std::make_shared<const std::string>(reinterpret_cast<const char*>(scratch_.data()),
                                                 scratch_.size()),
             true});
    return true;
  }

  ViewServer::Impl& s_;
  websocket::stream<beast::tcp_stream> ws_;
  beast::flat_buffer in_;
  std::uint64_t id_ = 0;  // 0 until accepted
  std::string remote_;
  std::vector<std::byte> scratch_;
  Outgoing current_;  // in flight (I/O thread)
  std::mutex m_;
  std::deque<Outgoing> q_;
  std::size_t queued_frames_ = 0;
  bool writing_ = false, closed_ = false;
  std::atomic<std::uint64_t> sent_{0}, dropped_{0};
};

/// An HTTP connection: static files, or the upgrade to a WebSocket on stream_path.
class HttpSession : public std::enable_shared_from_this<HttpSession> {
 public:
  HttpSession(ViewServer::Impl& server, tcp::socket&& socket)
      : s_(server), stream_(std::move(socket)) {}

  void run() { do_read(); }

  /// Closes the connection (idempotent); the server may accept again.
  void close() {
    if (closed_) return;
    closed_ = true;
    waiting_since_ = 0;
    beast::error_code ec;
    stream_.socket().shutdown(tcp::socket::shutdown_both, ec);
    stream_.socket().close(ec);
    s_.connection_closed();
  }
  /// Closed, or handed to a WebSocket client: no longer one of the server's HTTP connections.
  bool closed() const noexcept { return closed_; }
  /// When it began to wait for its request (the server's next_wait then); 0 while it is being
  /// answered, and once closed.
  std::uint64_t waiting_since() const noexcept { return waiting_since_; }

 private:
  void do_read() {
    parser_.emplace();
    parser_->header_limit(kViewHttpHeaderLimit);
    parser_->body_limit(kViewHttpBodyLimit);
    stream_.expires_after(std::chrono::seconds(30));
    waiting_since_ = s_.next_wait++;
    http::async_read(stream_, buf_, *parser_,
                     [self = shared_from_this()](beast::error_code ec, std::size_t) {
                       if (ec) return self->close();
                       self->waiting_since_ = 0;
                       self->on_request(self->parser_->release());
                     });
  }

  void on_request(http::request<http::string_body> req) {
    s_.http_requests.fetch_add(1, std::memory_order_relaxed);
    const bool keep_alive = req.keep_alive();
    const bool upgrade = websocket::is_upgrade(req);
    std::size_t n = 0;
    if (upgrade) {
      const std::lock_guard<std::mutex> lock(s_.clients_mutex);
      n = s_.clients.size();
    }
    const ViewHttpAnswer answer = answer_view_http_request(
        s_.settings, std::string_view(req.method_string().data(), req.method_string().size()),
        std::string_view(req.target().data(), req.target().size()), upgrade, n);
    using Kind = ViewHttpAnswer::Kind;
    switch (answer.kind) {
      case Kind::kUpgrade:
        closed_ = true;  // its socket is the client's now
        std::make_shared<WsSession>(s_, stream_.release_socket())->run(std::move(req));
        return;
      case Kind::kTooManyViewers:
        s_.refused.fetch_add(1, std::memory_order_relaxed);
        return send_text(http::status::service_unavailable, "too many viewers\n", req.version(),
                         false);
      case Kind::kNotAllowed:
        return send_text(http::status::method_not_allowed, "read-only\n", req.version(),
                         keep_alive);
      case Kind::kNotFound:
        return send_text(http::status::not_found, upgrade ? "no WebSocket here\n" : "not found\n",
                         req.version(), upgrade ? false : keep_alive);
      case Kind::kFile:
        break;
    }
    const std::string& rel = answer.file;
    const std::string path = s_.settings.static_dir + "/" + rel;
    http::file_body::value_type body;
    beast::error_code ec;
    body.open(path.c_str(), beast::file_mode::scan, ec);
    if (ec) return send_text(http::status::not_found, "not found\n", req.version(), keep_alive);
    const auto size = body.size();
    if (req.method() == http::verb::head) {
      auto res = std::make_shared<http::response<http::empty_body>>(http::status::ok, req.version());
      set_headers(*res, mime_type(rel), keep_alive);
      res->content_length(size);
      return send(std::move(res));
    }
    auto res = std::make_shared<http::response<http::file_body>>(
        std::piecewise_construct, std::make_tuple(std::move(body)),
        std::make_tuple(http::status::ok, req.version()));
    set_headers(*res, mime_type(rel), keep_alive);
    res->content_length(size);
    send(std::move(res));
  }

  template <class Res>
  static void set_headers(Res& res, const char* type, bool keep_alive) {
    res.set(http::field::server, "numen-view");
    res.set(http::field::content_type, type);
    res.set(http::field::cache_control, "no-cache");
    res.set("X-Content-Type-Options", "nosniff");
    res.keep_alive(keep_alive);
  }

  void send_text(http::status status, const char* text, unsigned version, bool keep_alive) {
    auto res = std::make_shared<http::response<http::string_body>>(status, version);
    set_headers(*res, "text/plain; charset=utf-8", keep_alive);
    res->body() = text;
    res->prepare_payload();
    send(std::move(res));
  }

  template <class Body>
  void send(std::shared_ptr<http::response<Body>> res) {
    const bool keep_alive = res->keep_alive();
    http::async_write(stream_, *res,
                      [self = shared_from_this(), res, keep_alive](beast::error_code ec, std::size_t) {
                        if (ec || !keep_alive) return self->close();
                        self->do_read();
                      });
  }

  ViewServer::Impl& s_;
  beast::tcp_stream stream_;
  beast::flat_buffer buf_;
  std::optional<http::request_parser<http::string_body>> parser_;
  std::uint64_t waiting_since_ = 0;
  bool closed_ = false;
};

ViewServer::Impl::Impl(const ViewServerSettings& s, std::string scene_message, ViewFrameSource* src,
                       const std::string& series)
    : settings(s), scene(std::make_shared<const std::string>(std::move(scene_message))), source(src) {
  if (settings.client_queue_frames < 1)
    throw std::invalid_argument("ViewServerSettings::client_queue_frames must be >= 1");
  if (settings.max_client_message_bytes < 16)
    throw std::invalid_argument("ViewServerSettings::max_client_message_bytes must be >= 16");
  if (settings.max_clients < 1)
    throw std::invalid_argument("ViewServerSettings::max_clients must be >= 1");
  if (settings.max_http_connections < 1)
    throw std::invalid_argument("ViewServerSettings::max_http_connections must be >= 1");
  if (settings.stream_path.empty() || settings.stream_path.front() != '/')
    throw std::invalid_argument("ViewServerSettings::stream_path must start with '/'");
  // The frames' layout from the declaration that encodes and decodes them: a recording's
  // frames passed this build's decoder (ViewRecordingReader), so it is theirs too.
  nlohmann::json j{{"type", "session"},
                   {"mode", source ? "replay" : "live"},
                   {"frame_layout", nlohmann::json::parse(state_frame_layout_json())}};
  if (source) {
    const std::size_t n = source->frame_count();
    nlohmann::json times = nlohmann::json::array();
    for (std::size_t i = 0; i < n; ++i)
      times.push_back(std::round(static_cast<double>(source->frame_time_ns(i)) * 1e-3) * 1e-6);
    j["frames"] = n;
    j["time_s"] = std::move(times);
    if (!series.empty()) {
      nlohmann::json sj = nlohmann::json::parse(series, nullptr, false);
      if (!sj.is_object())
        throw std::invalid_argument("ViewServer: the replay's series is not a JSON object");
      j["series"] = std::move(sj);
    }
  }
  session = std::make_shared<const std::string>(j.dump());
}

void ViewServer::Impl::do_accept() {
  acceptor.async_accept(ioc, [this](beast::error_code ec, tcp::socket socket) {
    if (ec == asio::error::operation_aborted || !acceptor.is_open()) return;
    // Out of descriptors (EMFILE, ENFILE) or memory (ENOBUFS, ENOMEM), the connection stays in
    // the listen queue: accepting again at once would fail again, as fast as the core runs.
    if (ec) return back_off();
    failures_in_a_row = 0;
    do_accept();  // first: a handler that throws (out of memory) leaves the loop accepting
    admit(std::move(socket));
  });
}

void ViewServer::Impl::back_off() {
  accept_failures.fetch_add(1, std::memory_order_relaxed);
  const int doublings = std::min(failures_in_a_row++, 16);
  const auto delay = std::min(kViewAcceptBackoff * (1 << doublings), kViewAcceptBackoffMax);
  accept_paused = true;
  const std::uint64_t pause = ++pause_id;
  backoff.expires_after(delay);
  backoff.async_wait([this, pause](beast::error_code) {
    // Not ended meanwhile by a connection that closed (a newer pause would have another id).
    if (accept_paused && pause == pause_id && acceptor.is_open()) resume_accept();
  });
}

void ViewServer::Impl::resume_accept() {
  accept_paused = false;
  ++pause_id;
  backoff.cancel();
  do_accept();
}

void ViewServer::Impl::connection_closed() {
  // A descriptor is free: a paused accept loop tries again now rather than at its timer.
  if (accept_paused && acceptor.is_open()) resume_accept();
}

void ViewServer::Impl::admit(tcp::socket socket) {
  std::erase_if(http_sessions, [](const std::weak_ptr<HttpSession>& w) {
    const auto h = w.lock();
    return !h || h->closed();
  });
  auto session = std::make_shared<HttpSession>(*this, std::move(socket));
  if (http_sessions.size() >= settings.max_http_connections) {
    // Room for the newcomer: the connection waiting longest for its request goes; when every
    // one is being answered, the newcomer.
    shed.fetch_add(1, std::memory_order_relaxed);
    std::shared_ptr<HttpSession> oldest;
    for (const auto& w : http_sessions)
      if (auto h = w.lock();
          h && h->waiting_since() != 0 && (!oldest || h->waiting_since() < oldest->waiting_since()))
        oldest = std::move(h);
    if (!oldest) return session->close();
    oldest->close();  // left in the list until the next admit() prunes it
  }
  http_sessions.push_back(session);
  session->run();
}

void ViewServer::Impl::add_client(const std::shared_ptr<WsSession>& c) {
  const std::lock_guard<std::mutex> lock(clients_mutex);
  clients.push_back(c);
  connected.store(clients.size(), std::memory_order_relaxed);
  total.fetch_add(1, std::memory_order_relaxed);
  client_added.notify_all();
}

void ViewServer::Impl::remove_client(const WsSession* c) {
  const std::lock_guard<std::mutex> lock(clients_mutex);
  std::erase_if(clients, [c](const std::shared_ptr<WsSession>& p) { return p.get() == c; });
  connected.store(clients.size(), std::memory_order_relaxed);
}

void ViewServer::Impl::close_all() {
  beast::error_code ec;
  acceptor.close(ec);
  accept_paused = false;
  backoff.cancel();
  for (const auto& w : http_sessions)
    if (auto h = w.lock()) h->close();
  http_sessions.clear();
  std::vector<std::shared_ptr<WsSession>> all;
  {
    const std::lock_guard<std::mutex> lock(clients_mutex);
    all = clients;
  }
  for (const auto& c : all) c->close(false);
}

ViewServer::ViewServer(const ViewServerSettings& settings, std::string scene_message)
    : impl_(std::make_unique<Impl>(settings, std::move(scene_message), nullptr, std::string())) {}

ViewServer::ViewServer(const ViewServerSettings& settings, std::string scene_message,
                       ViewFrameSource& source, const std::string& series)
    : impl_(std::make_unique<Impl>(settings, std::move(scene_message), &source, series)) {}

ViewServer::~ViewServer() { stop(); }

void ViewServer::start() {
  Impl& s = *impl_;
  if (s.started) return;
  const std::string host = s.settings.host == "localhost" ? "127.0.0.1" : s.settings.host;
  const std::string where = s.settings.host + ":" + std::to_string(s.settings.port);
  beast::error_code ec;
  const asio::ip::address address = asio::ip::make_address(host, ec);
  if (ec) throw std::runtime_error("viewer: " + where + ": not an IP address (" + ec.message() + ")");
  const tcp::endpoint endpoint(address, s.settings.port);
  s.acceptor.open(endpoint.protocol(), ec);
  if (!ec) s.acceptor.set_option(asio::socket_base::reuse_address(true), ec);
  if (!ec) s.acceptor.bind(endpoint, ec);
  if (!ec) s.acceptor.listen(asio::socket_base::max_listen_connections, ec);
  if (ec) {
    beast::error_code ignored;
    s.acceptor.close(ignored);
    throw std::runtime_error("viewer: cannot listen on " + where + ": " + ec.message());
  }
  s.bound_port = s.acceptor.local_endpoint().port();
  s.started = true;
  s.do_accept();
  s.thread = std::thread([&s] {
    for (;;) {
      try {
        s.ioc.run();
        return;
      } catch (...) {
        // A handler threw (out of memory): that connection is lost, the server goes on.
        s.source_errors.fetch_add(1, std::memory_order_relaxed);
      }
    }
  });
}

void ViewServer::stop() {
  Impl& s = *impl_;
  if (!s.started || s.stopped) return;
  s.stopped = true;
  asio::post(s.ioc, [&s] { s.close_all(); });
  s.thread.join();  // run() returns once every socket is closed and its handlers have run
  const std::lock_guard<std::mutex> lock(s.clients_mutex);
  s.clients.clear();
  s.connected.store(0, std::memory_order_relaxed);
}

std::uint16_t ViewServer::port() const noexcept { return impl_->bound_port; }

std::string ViewServer::url() const {
  const std::string& h = impl_->settings.host;
  const bool v6 = h.find(':') != std::string::npos;
  return "http://" + (v6 ? "[" + h + "]" : h) + ":" + std::to_string(port()) + "/";
}

bool ViewServer::wait_for_client(double timeout_s) {
  Impl& s = *impl_;
  std::unique_lock<std::mutex> lock(s.clients_mutex);
  return s.client_added.wait_for(lock, std::chrono::duration<double>(timeout_s),
                                 [&s] { return !s.clients.empty(); });
}

bool ViewServer::write_frame(std::span<const std::byte> frame) noexcept {
  Impl& s = *impl_;
  s.offered.fetch_add(1, std::memory_order_relaxed);
  if (s.connected.load(std::memory_order_relaxed) == 0) return true;
  try {
    Outgoing o{std::make_shared<const std::string>(reinterpret_cast<const char*>(frame.data()),
                                                   frame.size()),
               true};
    const std::lock_guard<std::mutex> lock(s.clients_mutex);
    for (const auto& c : s.clients) c->enqueue(o);
    return true;
  } catch (...) {
    return false;
  }
}

ViewServerCounters ViewServer::counters() const noexcept {
  const Impl& s = *impl_;
  const auto r = std::memory_order_relaxed;
  return {s.connected.load(r),     s.total.load(r),           s.refused.load(r),
          s.http_requests.load(r), s.offered.load(r),         s.sent.load(r),
          s.dropped.load(r),       s.bad_input.load(r),       s.requests.load(r),
          s.source_errors.load(r), s.accept_failures.load(r), s.shed.load(r)};
}

std::vector<ViewClientCounters> ViewServer::clients() const {
  std::vector<ViewClientCounters> out;
  const std::lock_guard<std::mutex> lock(impl_->clients_mutex);
  for (const auto& c : impl_->clients) out.push_back(c->counters());
  return out;
}

bool ViewServer::is_address(const std::string& host) {
  if (host == "localhost") return true;
  beast::error_code ec;
  asio::ip::make_address(host, ec);
  return !ec;
}

bool ViewServer::is_loopback_address(const std::string& host) {
  if (host == "localhost") return true;
  beast::error_code ec;
  const asio::ip::address a = asio::ip::make_address(host, ec);
  return !ec && a.is_loopback();
}

}  // namespace numen::sim
