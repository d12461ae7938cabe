// OBJ and PLY meshes (`relume process --mesh`, a scene's meshes): core/mesh_io.h. The first
// byte chooses the format (even: OBJ, odd: PLY); the rest is the file.
#include "core/mesh_io.h"
#include "fuzz/fuzz_util.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  if (size == 0) return 0;
  const bool ply = (data[0] & 1) != 0;
  const auto path = relume::fuzz::WriteScratch(ply ? "mesh.ply" : "mesh.obj", {data + 1, size - 1});
  relume::fuzz::ExpectRelumeErrorsOnly([&] {
    if (ply) {
      relume::LoadPlyMesh(path.string());
    } else {
      relume::LoadObjMesh(path.string());
    }
  });
  return 0;
}
