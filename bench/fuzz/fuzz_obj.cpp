// meshcvt fuzzing: libFuzzer entry point for the OBJ reader (see fuzz_reader.h, run.sh).
#include "fuzz_reader.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  return meshcvt_fuzz::read_one(data, size, ".obj");
}
