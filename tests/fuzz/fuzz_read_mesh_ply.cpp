// read_mesh on a fuzzed .ply mesh (a mesh format `mfpc synth` reads; the seeds are built-in
// objects written by make_seeds). Asserts the reader's contract and samples the mesh's surface
// (mesh_checks.hpp).
#include "mesh_checks.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size)
{
    using namespace mfpc;
    const auto path = fuzz::write_input("mesh.ply", data, size);
    fuzz::run([&] { fuzz::check_mesh(read_mesh(path)); });
    return 0;
}
