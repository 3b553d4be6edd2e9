/* For scripts/pi.sh: lets the Raspberry Pi's orch (aarch64, built with `link`) find its Link
 * peers under qemu-user, which answers setsockopt(IP_MULTICAST_IF) with ENOPROTOOPT (qemu 7.2
 * passes IP_ADD_MEMBERSHIP and IP_MULTICAST_TTL/LOOP through, not this one).
 *
 * Loaded into orch (qemu-aarch64 -E LD_PRELOAD=...), it answers that one option with success
 * and passes every other call to the C library. Nothing is lost by it where the test runs it:
 * Ableton's SDK sets IP_MULTICAST_IF on a socket it has bound to the interface's own address,
 * and Linux sends a multicast datagram from a socket bound to an address out of that address's
 * interface when no IP_MULTICAST_IF is set (the namespace has one interface besides lo). */
#define _GNU_SOURCE
#include <dlfcn.h>
#include <netinet/in.h>
#include <sys/socket.h>

int setsockopt(int fd, int level, int name, const void *value, socklen_t length) {
    static int (*real)(int, int, int, const void *, socklen_t);
    if (level == IPPROTO_IP && name == IP_MULTICAST_IF) {
        return 0;
    }
    if (!real) {
        real = (int (*)(int, int, int, const void *, socklen_t))dlsym(RTLD_NEXT, "setsockopt");
    }
    return real(fd, level, name, value, length);
}
