/* Test-only stand-in for bcryptprimitives.dll, for running Windows binaries under Wine 8.0
 * (Debian 12), which lacks it. Rust's standard library (1.78 and later) imports
 * bcryptprimitives!ProcessPrng on Windows; every Windows 10 and later has the real DLL, so
 * this file is never shipped: the tests put it on Wine's search path (WINEPATH).
 *
 * ProcessPrng fills the buffer with random bytes from advapi32's RtlGenRandom
 * (SystemFunction036), which Wine has, and always returns TRUE, as the real one does. */
#include <windows.h>

BOOLEAN WINAPI SystemFunction036(PVOID buffer, ULONG length);

__declspec(dllexport) BOOL WINAPI ProcessPrng(PBYTE data, SIZE_T length) {
    while (length > 0) {
        ULONG chunk = length > 0x40000000u ? 0x40000000u : (ULONG)length;
        if (!SystemFunction036(data, chunk)) return FALSE;
        data += chunk;
        length -= chunk;
    }
    return TRUE;
}
