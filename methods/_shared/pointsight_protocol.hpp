// The external-method protocol of pointsight (../README.md), for methods written in C++:
// header-only, the standard library alone. What every method program shares: its arguments
// (parse_args), the points file pointsight writes (read_xyz: binary little-endian PLY, x y z
// doubles first, other properties skipped), the few JSON values a request carries
// (json_member, json_number, json_triple, param_number) and the JSON-lines loop (serve,
// send_visible, send_error: one request line in, one answer line out, flushed).
//
// Protocols 1, 2 and 3 alike: serve hands the method each request's line, its camera's eye and
// its setting, the request's "params" object (protocol 3 sends one with every request, the
// keys given; without one, the start-up --params of protocols 1 and 2); send_visible and
// send_error answer the request serve is on, echoing its "id" as their first field when it has
// one (protocol 3). A method that reads its setting from the params serve hands it serves
// every setting from one process.
//
// A method includes it as
//
//   #include "../_shared/pointsight_protocol.hpp"
//
// Nothing here knows a method: the answers are the method's.
#ifndef POINTSIGHT_PROTOCOL_HPP
#define POINTSIGHT_PROTOCOL_HPP

#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <iostream>
#include <sstream>
#include <stdexcept>
#include <string>
#include <type_traits>
#include <vector>

namespace pointsight_protocol {

// The arguments pointsight appends: --points FILE --protocol P, --params JSON (protocols 1 and
// 2: the one setting; protocol 3 sends none, each request carries its own), protocols 2 and 3's
// --normals W --spacing S (others ignored); --version asks for the tool's version line.
struct Args {
  std::string points;
  std::string params = "{}";  // the default setting: absent keys mean the method's defaults
  int protocol = 1;
  double spacing = 0.0;  // 0: not sent
  bool version = false;
};

inline Args parse_args(int argc, char** argv) {
  Args a;
  for (int i = 1; i < argc; ++i) {
    std::string w = argv[i];
    if (w == "--version") a.version = true;
    else if (i + 1 < argc && w == "--points") a.points = argv[++i];
    else if (i + 1 < argc && w == "--params") a.params = argv[++i];
    else if (i + 1 < argc && w == "--spacing") a.spacing = std::strtod(argv[++i], nullptr);
    else if (i + 1 < argc && w == "--protocol") a.protocol = std::atoi(argv[++i]);
    else if (i + 1 < argc && w == "--normals") ++i;
  }
  return a;
}

inline size_t ply_type_size(const std::string& t) {
  if (t == "double" || t == "float64") return 8;
  if (t == "float" || t == "float32" || t == "int" || t == "uint" || t == "int32" ||
      t == "uint32")
    return 4;
  if (t == "short" || t == "ushort" || t == "int16" || t == "uint16") return 2;
  if (t == "char" || t == "uchar" || t == "int8" || t == "uint8") return 1;
  throw std::runtime_error("unknown PLY property type " + t);
}

// The points' x y z (3 doubles a point) from pointsight's binary little-endian PLY: the vertex
// element starts with double x y z; its other properties (normals, colours, uv) are skipped.
inline std::vector<double> read_xyz(const std::string& path) {
  std::ifstream f(path, std::ios::binary);
  if (!f) throw std::runtime_error("cannot open " + path);
  std::string line;
  size_t n = 0, stride = 0, props = 0;
  bool in_vertex = false;
  while (std::getline(f, line)) {
    std::istringstream s(line);
    std::string w;
    s >> w;
    if (w == "format") {
      std::string fmt;
      s >> fmt;
      if (fmt != "binary_little_endian") throw std::runtime_error("PLY is not binary LE");
    } else if (w == "element") {
      std::string e;
      s >> e;
      in_vertex = e == "vertex";
      if (in_vertex) s >> n;
    } else if (w == "property" && in_vertex) {
      std::string t, name;
      s >> t >> name;
      if (t == "list") throw std::runtime_error("list property in vertex element");
      if (props < 3 && (name != std::string(1, char('x' + props)) || ply_type_size(t) != 8))
        throw std::runtime_error("vertex element does not start with double x y z");
      ++props;
      stride += ply_type_size(t);
    } else if (w == "end_header") {
      break;
    }
  }
  if (props < 3) throw std::runtime_error("vertex element does not start with double x y z");
  if (n > (size_t(1) << 32)) throw std::runtime_error("absurd vertex count");
  std::vector<double> xyz(3 * n);
  std::vector<char> row(stride);
  for (size_t i = 0; i < n; ++i) {
    if (!f.read(row.data(), stride)) throw std::runtime_error("PLY body is short");
    std::memcpy(&xyz[3 * i], row.data(), 24);
  }
  return xyz;
}

inline size_t json_skip_space(const std::string& s, size_t p) {
  while (p < s.size() && (s[p] == ' ' || s[p] == '\t' || s[p] == '\r' || s[p] == '\n')) ++p;
  return p;
}

// The index just past the JSON value that starts at `p` (a string, an object or an array,
// brackets matched outside strings, or a scalar); npos when it does not end.
inline size_t json_skip_value(const std::string& s, size_t p) {
  if (p >= s.size()) return std::string::npos;
  if (s[p] == '"') {
    for (++p; p < s.size(); ++p) {
      if (s[p] == '\\') ++p;
      else if (s[p] == '"') return p + 1;
    }
    return std::string::npos;
  }
  if (s[p] == '{' || s[p] == '[') {
    int depth = 0;
    for (; p < s.size(); ++p) {
      char ch = s[p];
      if (ch == '"') {
        p = json_skip_value(s, p);
        if (p == std::string::npos) return p;
        --p;
      } else if (ch == '{' || ch == '[') {
        ++depth;
      } else if (ch == '}' || ch == ']') {
        if (--depth == 0) return p + 1;
      }
    }
    return std::string::npos;
  }
  while (p < s.size() && s[p] != ',' && s[p] != '}' && s[p] != ']' && s[p] != ' ' &&
         s[p] != '\t' && s[p] != '\r' && s[p] != '\n')
    ++p;
  return p;
}

// The text of the value of `key`, a member of the JSON object `json` itself (not of one nested
// in it): an object or array whole, a string with its quotes, a number as written. False when
// `json` is not an object or has no such member.
inline bool json_member(const std::string& json, const std::string& key, std::string& out) {
  size_t p = json_skip_space(json, 0);
  if (p >= json.size() || json[p] != '{') return false;
  p = json_skip_space(json, p + 1);
  while (p < json.size() && json[p] == '"') {
    size_t key_end = json_skip_value(json, p);
    if (key_end == std::string::npos) return false;
    bool match = json.compare(p + 1, key_end - p - 2, key) == 0;
    p = json_skip_space(json, key_end);
    if (p >= json.size() || json[p] != ':') return false;
    p = json_skip_space(json, p + 1);
    size_t end = json_skip_value(json, p);
    if (end == std::string::npos || end == p) return false;
    if (match) {
      out = json.substr(p, end - p);
      return true;
    }
    p = json_skip_space(json, end);
    if (p >= json.size() || json[p] != ',') return false;
    p = json_skip_space(json, p + 1);
  }
  return false;
}

// The number after "key": in a flat JSON object (quoted or not); false when absent.
inline bool json_number(const std::string& json, const std::string& key, double& out) {
  std::string k = "\"" + key + "\"";
  size_t p = json.find(k);
  if (p == std::string::npos) return false;
  p = json.find(':', p + k.size());
  if (p == std::string::npos) return false;
  ++p;
  while (p < json.size() && (json[p] == ' ' || json[p] == '"')) ++p;
  char* end = nullptr;
  out = std::strtod(json.c_str() + p, &end);
  return end != json.c_str() + p;
}

// A setting's number: the member `key` of a params object (`{"gamma": "3"}`: strings, as
// pointsight sends them, or numbers). False when absent; a value that is not a finite number
// throws std::invalid_argument (serve answers the request with its message).
inline bool param_number(const std::string& params, const std::string& key, double& out) {
  std::string v;
  if (!json_member(params, key, v)) return false;
  std::string text = v.size() >= 2 && v.front() == '"' ? v.substr(1, v.size() - 2) : v;
  const char* s = text.c_str();
  char* end = nullptr;
  double x = std::strtod(s, &end);
  if (end == s || json_skip_space(text, size_t(end - s)) != text.size() || !std::isfinite(x))
    throw std::invalid_argument(key + "=" + text + ": not a number");
  out = x;
  return true;
}

// The three numbers of the array after "key" (a request's camera "eye"); false when absent.
inline bool json_triple(const std::string& json, const std::string& key, double out[3]) {
  std::string k = "\"" + key + "\"";
  size_t p = json.find(k);
  if (p == std::string::npos) return false;
  p = json.find('[', p + k.size());
  if (p == std::string::npos) return false;
  const char* s = json.c_str() + p + 1;
  for (int i = 0; i < 3; ++i) {
    char* end = nullptr;
    out[i] = std::strtod(s, &end);
    if (end == s) return false;
    s = end;
    while (*s == ' ' || *s == ',') ++s;
  }
  return true;
}

// `s` as the inside of a JSON string.
inline std::string escape(const std::string& s) {
  std::string o;
  for (char ch : s) {
    if (ch == '"' || ch == '\\') o += '\\';
    if (ch == '\n') {
      o += "\\n";
      continue;
    }
    o += ch;
  }
  return o;
}

inline void send_line(const std::string& line) {
  std::fwrite(line.data(), 1, line.size(), stdout);
  std::fflush(stdout);
}

// The request serve is on: its "id" as sent (empty: it had none, or serve is on none) and
// whether it has been answered.
struct Request {
  std::string id;
  bool answered = false;
};

inline Request& current_request() {
  static Request request;
  return request;
}

// `{"id":N,` when the current request has an id, else `{`: an answer's start.
inline std::string answer_start() {
  Request& r = current_request();
  r.answered = true;
  return r.id.empty() ? std::string("{") : "{\"id\":" + r.id + ",";
}

// {"id":N,"error":"message"} (no id when the request had none, or before the first).
inline void send_error(const std::string& message) {
  send_line(answer_start() + "\"error\":\"" + escape(message) + "\"}\n");
}

// {"id":N,"visible":[i,...]<extra>,"seconds":T} (no id when the request had none): `extra` the
// method's own fields, each starting with a comma.
inline void send_visible(const std::vector<uint32_t>& visible, const std::string& extra,
                         double seconds) {
  std::string out = answer_start() + "\"visible\":[";
  for (size_t k = 0; k < visible.size(); ++k) {
    if (k) out += ',';
    out += std::to_string(visible[k]);
  }
  out += ']';
  out += extra;
  char tail[64];
  std::snprintf(tail, sizeof tail, ",\"seconds\":%.9g}\n", seconds);
  out += tail;
  send_line(out);
}

// The loop: for each request line on standard input, `view(line, eye, params)` with the
// camera's eye and the request's setting, its "params" object's text (`default_params`, the
// start-up --params, when it has none; a view taking only (line, eye) is called so), which
// answers with send_visible or send_error. Exactly one answer a request: a request without an
// eye, or whose params is not an object, is answered with an error; so is one whose view throws
// a std::exception (its message) or returns unanswered, and the loop goes on. End of input
// ends it.
template <class View>
void serve(View view, const std::string& default_params = "{}") {
  std::string line, camera, params;
  Request& request = current_request();
  while (std::getline(std::cin, line)) {
    request.answered = false;
    if (!json_member(line, "id", request.id)) request.id.clear();
    double eye[3];
    bool has_camera = json_member(line, "camera", camera);
    bool has_params = json_member(line, "params", params);
    if (!json_triple(has_camera ? camera : line, "eye", eye)) {
      send_error("request has no camera eye");
    } else if (has_params && params[0] != '{') {
      send_error("the request's params is not a JSON object");
    } else {
      if (!has_params) params = default_params;
      try {
        if constexpr (std::is_invocable_v<View&, const std::string&, const double*,
                                          const std::string&>)
          view(line, eye, params);
        else
          view(line, eye);
        if (!request.answered) send_error("the method gave no answer");
      } catch (const std::exception& e) {
        if (!request.answered) send_error(e.what());
      }
    }
    request.id.clear();
  }
}

}  // namespace pointsight_protocol

#endif
