/* For scripts/pi.sh: lets the Raspberry Pi's orch (aarch64, built with `link`) find its Link
 * peers under qemu-user 7.2, which answers three socket options Ableton's SDK sets with
 * ENOPROTOOPT (it passes IP_ADD_MEMBERSHIP and IP_MULTICAST_TTL/LOOP through, not these),
 * and the SDK then opens no interface at all.
 *
 * Loaded into orch (qemu-aarch64 -E LD_PRELOAD=...), it answers those three with success and
 * passes every other call to the C library. Nothing is lost by it where the test runs it, a
 * network namespace with one interface besides lo:
 * - IP_MULTICAST_IF and IPV6_MULTICAST_IF (which interface multicast leaves by): the SDK sets
 *   them on a socket it has bound to that interface's own address, and Linux sends multicast
 *   from such a socket out of that address's interface when none is set;
 * - IP_MULTICAST_ALL = 0 (a socket hears only the groups joined on it): the namespace's only
 *   group on Link's port is Link's own. */
#define _GNU_SOURCE
#include <dlfcn.h>
#include <netinet/in.h>
#include <sys/socket.h>

static int answered(int level, int name) {
    return (level == IPPROTO_IP && (name == IP_MULTICAST_IF || name == IP_MULTICAST_ALL)) ||
           (level == IPPROTO_IPV6 && name == IPV6_MULTICAST_IF);
}

int setsockopt(int fd, int level, int name, const void *value, socklen_t length) {
    static int (*real)(int, int, int, const void *, socklen_t);
    if (answered(level, name)) {
        return 0;
    }
    if (!real) {
        real = (int (*)(int, int, int, const void *, socklen_t))dlsym(RTLD_NEXT, "setsockopt");
    }
    return real(fd, level, name, value, length);
}
