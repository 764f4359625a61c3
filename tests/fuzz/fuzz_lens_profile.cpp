// libFuzzer target over the lens-profile reader: random bytes as a calibration file
// (Gyroflow JSON or an OpenCV FileStorage file). Whatever the file holds, readLensProfile
// returns a validated lens or throws LensProfileError; any other exception, crash or memory
// error (ASan/UBSan) is a finding.
//
//   build-fuzz/tests/fuzz/fuzz_lens_profile -max_total_time=60 tests/fuzz/lens_corpus
#include <cstdint>
#include <cstdio>
#include <string>
#include <unistd.h>

#include "uavstab/lens.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t *data, std::size_t size)
{
    // The reader takes a path: the bytes go to a file of this process's own. Its name ends
    // in .json or .yml by the first byte, so both readers are reached.
    static const std::string base = "/tmp/uavstab_fuzz_lens_" + std::to_string(getpid());
    const std::string path = base + (size > 0 && (data[0] & 1) ? ".yml" : ".json");
    if (std::FILE *f = std::fopen(path.c_str(), "wb")) {
        std::fwrite(data, 1, size, f);
        std::fclose(f);
    } else {
        return 0;
    }
    try {
        const uavstab::LensProfile p = uavstab::readLensProfile(path);
        p.lens.validate();  // what it returns is valid: validate() must not throw now
        (void)p.lens.undistort(p.lens.distort({0.0, 0.0}));
    } catch (const uavstab::LensProfileError &) {
    }
    std::remove(path.c_str());
    return 0;
}
