// Reads a mesh through an installed meshcvt and prints its face count: proves the package config.
#include <meshcvt/io.h>
#include <meshcvt/topology.h>

#include <cstdio>

int main(int argc, char** argv) {
  if (argc != 2) return 2;
  meshcvt::Mesh mesh = meshcvt::read_mesh(argv[1]);
  meshcvt::Topology topology = meshcvt::build_topology(mesh);
  std::printf("consumer: %zu faces, %u components\n", mesh.face_count(), topology.component_count);
  return mesh.face_count() > 0 ? 0 : 1;
}
