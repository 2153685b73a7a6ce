// The external-method protocol of pointsight (../README.md), for methods written in C++:
// header-only, the standard library alone. What every method program shares: its arguments
// (parse_args), the points file pointsight writes (read_xyz: binary little-endian PLY, x y z
// doubles first, other properties skipped), the few JSON values a request carries
// (json_number, json_triple) and the JSON-lines loop (serve, send_visible, send_error: one
// request line in, one answer line out, flushed). A method includes it as
//
//   #include "../_shared/pointsight_protocol.hpp"
//
// Nothing here knows a method: the answers are the method's.
#ifndef POINTSIGHT_PROTOCOL_HPP
#define POINTSIGHT_PROTOCOL_HPP

#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <iostream>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

namespace pointsight_protocol {

// The arguments pointsight appends: --points FILE --params JSON --protocol P, protocol 2's
// --normals W --spacing S (others ignored); --version asks for the tool's version line.
struct Args {
  std::string points;
  std::string params = "{}";
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
    else if (i + 1 < argc && (w == "--protocol" || w == "--normals")) ++i;
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

// {"error":"message"}
inline void send_error(const std::string& message) {
  send_line("{\"error\":\"" + escape(message) + "\"}\n");
}

// {"visible":[i,...]<extra>,"seconds":T}: `extra` the method's own fields, each starting with
// a comma.
inline void send_visible(const std::vector<uint32_t>& visible, const std::string& extra,
                         double seconds) {
  std::string out = "{\"visible\":[";
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

// The loop: for each request line on standard input, `view(line, eye)` with the camera's eye
// (which answers with send_visible or send_error); a request without one is answered with an
// error. End of input ends it.
template <class View>
void serve(View view) {
  std::string line;
  while (std::getline(std::cin, line)) {
    double eye[3];
    if (!json_triple(line, "eye", eye)) {
      send_error("request has no camera eye");
      continue;
    }
    view(line, eye);
  }
}

}  // namespace pointsight_protocol

#endif
