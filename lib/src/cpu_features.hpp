// What the CPU can run, asked once: the vector kernels choose their code with it.
#pragma once

#if defined(__x86_64__) || defined(__i386__)
#define UAVSTAB_HAVE_X86 1
#endif

namespace uavstab {

#ifdef UAVSTAB_HAVE_X86
inline bool cpuHasAvx2()
{
    static const bool has = __builtin_cpu_supports("avx2");
    return has;
}
#endif

} // namespace uavstab
