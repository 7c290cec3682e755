// A pinhole camera over a kdray scene, from C++: one closest-hit ray per
// pixel in an rtcIntersect1-shaped loop, a shadow ray toward a light for
// each hit, and the picture printed as characters. Writes the camera rays
// and their hits so capi/tests/run.sh can compare them with `kdray trace`.
//
// usage: camera BLOB WIDTH HEIGHT OUT_RAYS OUT_HITS [EYE_X EYE_Y EYE_Z TARGET_X TARGET_Y TARGET_Z]
// (the default view looks at the unit cube from in front of its z = 0 face)
#include "kdray.h"

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <iterator>
#include <string>
#include <vector>

namespace {

struct Vec3 {
  float x, y, z;
};
Vec3 operator+(Vec3 a, Vec3 b) { return {a.x + b.x, a.y + b.y, a.z + b.z}; }
Vec3 operator-(Vec3 a, Vec3 b) { return {a.x - b.x, a.y - b.y, a.z - b.z}; }
Vec3 operator*(float s, Vec3 a) { return {s * a.x, s * a.y, s * a.z}; }
Vec3 cross(Vec3 a, Vec3 b) { return {a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x}; }
Vec3 normalize(Vec3 a) { return (1.0f / std::sqrt(a.x * a.x + a.y * a.y + a.z * a.z)) * a; }

// The blob in memory the caller owns; std::vector<uint64_t> keeps it 8-byte aligned.
std::vector<uint64_t> read_blob(const char* path, size_t& len) {
  std::ifstream f(path, std::ios::binary);
  std::vector<char> bytes((std::istreambuf_iterator<char>(f)), std::istreambuf_iterator<char>());
  if (!f.good() && !f.eof()) {
    std::fprintf(stderr, "cannot read %s\n", path);
    std::exit(2);
  }
  len = bytes.size();
  std::vector<uint64_t> words((len + 7) / 8);
  if (len) std::copy(bytes.begin(), bytes.end(), reinterpret_cast<char*>(words.data()));
  return words;
}

template <typename T>
void write_records(const char* path, const std::vector<T>& v) {
  std::ofstream f(path, std::ios::binary);
  f.write(reinterpret_cast<const char*>(v.data()), static_cast<std::streamsize>(v.size() * sizeof(T)));
  if (!f) {
    std::fprintf(stderr, "cannot write %s\n", path);
    std::exit(2);
  }
}

}  // namespace

int main(int argc, char** argv) {
  if (argc != 6 && argc != 12) {
    std::fprintf(stderr, "usage: %s BLOB WIDTH HEIGHT OUT_RAYS OUT_HITS [EYE(3) TARGET(3)]\n", argv[0]);
    return 2;
  }
  size_t len = 0;
  std::vector<uint64_t> blob = read_blob(argv[1], len);
  KdrayTriangleTree scene;
  char message[256];
  if (kdray_triangles_open(&scene, reinterpret_cast<const uint8_t*>(blob.data()), len, message, sizeof message) !=
      KDRAY_STATUS_OK) {
    std::fprintf(stderr, "%s: %s\n", argv[1], message);
    return 1;
  }
  const int width = std::atoi(argv[2]), height = std::atoi(argv[3]);
  Vec3 eye{0.5f, 0.5f, -2.0f}, target{0.5f, 0.5f, 0.5f};
  if (argc == 12) {
    eye = {std::strtof(argv[6], nullptr), std::strtof(argv[7], nullptr), std::strtof(argv[8], nullptr)};
    target = {std::strtof(argv[9], nullptr), std::strtof(argv[10], nullptr), std::strtof(argv[11], nullptr)};
  }
  const Vec3 forward = normalize(target - eye);
  const Vec3 right = normalize(cross(Vec3{0, 1, 0}, forward));
  const Vec3 up = cross(forward, right);
  const float half = std::tan(0.5f * 45.0f * 3.14159265f / 180.0f);
  const Vec3 light{2.0f, 3.0f, -3.0f};

  std::vector<KdrayRay> rays;
  std::vector<KdrayHit> hits;
  std::string picture;
  for (int y = 0; y < height; y++) {
    for (int x = 0; x < width; x++) {
      // Pixel centre on the image plane one unit in front of the eye.
      const float sx = (2.0f * (x + 0.5f) / width - 1.0f) * half * width / height;
      const float sy = (1.0f - 2.0f * (y + 0.5f) / height) * half;
      const Vec3 d = forward + sx * right + sy * up;
      KdrayRay ray{eye.x, eye.y, eye.z, 0.0f, d.x, d.y, d.z, INFINITY};
      KdrayHit hit;
      if (kdray_closest_hit(&scene, &ray, &hit) != KDRAY_STATUS_OK) return 1;
      rays.push_back(ray);
      hits.push_back(hit);

      char c = ' ';
      if (hit.prim_id != KDRAY_MISS) {
        const Vec3 p = eye + hit.t * d;
        const Vec3 to_light = light - p;
        KdrayRay shadow{p.x, p.y, p.z, 1e-3f, to_light.x, to_light.y, to_light.z, 1.0f};
        int32_t occluded = 0;
        if (kdray_any_hit(&scene, &shadow, &occluded) != KDRAY_STATUS_OK) return 1;
        c = occluded ? '.' : "#%*+=o"[hit.prim_id % 6];
      }
      picture += c;
    }
    picture += '\n';
  }
  std::fputs(picture.c_str(), stdout);
  write_records(argv[4], rays);
  write_records(argv[5], hits);
  return 0;
}
