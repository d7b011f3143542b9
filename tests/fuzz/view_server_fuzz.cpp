/// @file view_server_fuzz.cpp
/// libFuzzer harness of what the viewer's HTTP and WebSocket server (sim/view/view_server.hpp)
/// makes of a client's bytes, without a socket: the parsing of Boost.Beast with the server's limits
/// (kViewHttpHeaderLimit, kViewHttpBodyLimit, max_client_message_bytes) and the server's own
/// decisions on what it parsed (answer_view_http_request(), read_view_client_message(), the
/// seam the sessions call). The input's last byte picks:
///  - HTTP: the input as the bytes of one connection, request after request (keep-alive),
///    each answered; an upgrade the server accepts goes on as WebSocket with the rest;
///  - WebSocket: a valid upgrade request, then the input as the client's frames, each message
///    read (a Beast WebSocket stream, server role, over beast::test::stream in memory);
///  - message: the input as one client message (text or binary, live or replay).
/// Checks: a file answer is a relative path of [A-Za-z0-9._/-] without ".." or an empty
/// segment; a frame request is below the frame count; only a text message is ever accepted.

#include <boost/asio/io_context.hpp>
#include <boost/beast/_experimental/test/stream.hpp>
#include <boost/beast/core.hpp>
#include <boost/beast/http.hpp>
#include <boost/beast/websocket.hpp>
#include <cctype>
#include <cstdint>
#include <string>
#include <string_view>

#include "fuzz_input.hpp"
#include "numen/sim/view/view_server.hpp"

namespace {

namespace beast = boost::beast;
namespace http = beast::http;
namespace websocket = beast::websocket;
using numen::fuzz::finding;
using numen::sim::ViewClientRequest;
using numen::sim::ViewHttpAnswer;

struct Setup {
  numen::sim::ViewServerSettings settings;
  bool replay = false;
  std::size_t frames = 0;
  std::size_t clients = 0;
};

void check_message(const Setup& s, std::string_view message, bool text) {
  const ViewClientRequest r =
      numen::sim::read_view_client_message(message, text, s.replay, s.frames);
  if (r.kind != ViewClientRequest::Kind::kBad && !text) finding("view server: binary accepted");
  if (r.kind == ViewClientRequest::Kind::kFrame && (!s.replay || r.frame >= s.frames))
    finding("view server: a frame request out of range", message);
  if (r.kind == ViewClientRequest::Kind::kIgnored && s.replay)
    finding("view server: replay ignores a message", message);
}

/// The WebSocket session after `req` (an upgrade) with `frames` the client's bytes.
void websocket_session(const Setup& s, const http::request<http::string_body>& req,
                       std::string_view frames) {
  boost::asio::io_context ioc;
  websocket::stream<beast::test::stream> ws(ioc);
  beast::test::stream peer(ioc);  // takes what the server writes
  ws.next_layer().connect(peer);
  ws.next_layer().append(beast::string_view(frames.data(), frames.size()));
  ws.next_layer().close_remote();  // the server reads EOF after the input
  ws.read_message_max(s.settings.max_client_message_bytes);
  beast::error_code ec;
  ws.accept(req, ec);
  if (ec) return;
  beast::flat_buffer buffer;
  for (;;) {
    ws.read(buffer, ec);
    if (ec) return;
    const std::string message = beast::buffers_to_string(buffer.data());
    buffer.consume(buffer.size());
    check_message(s, message, ws.got_text());
    if (numen::sim::read_view_client_message(message, ws.got_text(), s.replay, s.frames).kind ==
        ViewClientRequest::Kind::kBad)
      return;  // the server closes the connection
  }
}

/// `bytes` as one HTTP connection.
void http_connection(const Setup& s, std::string_view bytes) {
  beast::flat_buffer buffer;
  buffer.commit(boost::asio::buffer_copy(buffer.prepare(bytes.size()),
                                         boost::asio::buffer(bytes.data(), bytes.size())));
  while (buffer.size() > 0) {
    http::request_parser<http::string_body> parser;
    parser.header_limit(numen::sim::kViewHttpHeaderLimit);
    parser.body_limit(numen::sim::kViewHttpBodyLimit);
    parser.eager(true);
    beast::error_code ec;
    while (!parser.is_done()) {
      const std::size_t n = parser.put(buffer.data(), ec);
      buffer.consume(n);
      if (ec == http::error::need_more) {
        if (buffer.size() > 0 && n > 0) {
          ec = {};
          continue;
        }
        parser.put_eof(ec);  // the connection ends here
        if (ec || !parser.is_done()) return;
        break;
      }
      if (ec) return;  // the server closes the connection
      if (n == 0 && !parser.is_done()) return;
    }
    http::request<http::string_body> req = parser.release();
    const bool upgrade = websocket::is_upgrade(req);
    const ViewHttpAnswer a = numen::sim::answer_view_http_request(
        s.settings, std::string_view(req.method_string().data(), req.method_string().size()),
        std::string_view(req.target().data(), req.target().size()), upgrade, s.clients);
    if (a.kind == ViewHttpAnswer::Kind::kFile) {
      const std::string& f = a.file;
      if (f.empty() || f.front() == '/' || f.find("..") != std::string::npos ||
          f.find("//") != std::string::npos)
        finding("view server: a file outside the folder", f);
      for (const char c : f)
        if (!(std::isalnum(static_cast<unsigned char>(c)) || c == '.' || c == '_' || c == '/' ||
              c == '-'))
          finding("view server: a file name with a byte not served", f);
    }
    if (a.kind == ViewHttpAnswer::Kind::kUpgrade) {
      const auto rest = beast::buffers_to_string(buffer.data());
      return websocket_session(s, req, rest);
    }
    if (upgrade || !req.keep_alive()) return;  // answered, then closed
  }
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  if (size == 0) return 0;
  const std::uint8_t how = data[size - 1];
  const std::string_view bytes(reinterpret_cast<const char*>(data), size - 1);
  Setup s;
  s.settings.static_dir = (how & 4) != 0 ? "www" : "";
  s.replay = (how & 8) != 0;
  s.frames = (how >> 4) & 7;
  s.clients = (how & 0x80) != 0 ? s.settings.max_clients : 0;
  switch (how & 3) {
    case 0:
    case 3: http_connection(s, bytes); break;
    case 1: {
      http::request<http::string_body> req{http::verb::get, s.settings.stream_path, 11};
      req.set(http::field::host, "127.0.0.1");
      req.set(http::field::upgrade, "websocket");
      req.set(http::field::connection, "Upgrade");
      req.set(http::field::sec_websocket_key, "dGhlIHNhbXBsZSBub25jZQ==");
      req.set(http::field::sec_websocket_version, "13");
      websocket_session(s, req, bytes);
      break;
    }
    default: check_message(s, bytes, (how & 0x40) == 0); break;
  }
  return 0;
}
