#!/bin/sh
# Runs a test program in a private network namespace with only loopback up, so DDS
# traffic of concurrent tests (and of anything else on the host) can never meet. Falls
# back to running it directly when namespaces are not available (then the private
# domain id and the loopback-only Cyclone config keep tests apart).
if command -v unshare >/dev/null 2>&1 && command -v ip >/dev/null 2>&1 &&
   unshare -rn true >/dev/null 2>&1; then
  # TC_PRIVATE_NETNS tells tests they may change the namespace's network (packet loss).
  exec unshare -rn sh -c 'ip link set lo up && TC_PRIVATE_NETNS=1 exec "$@"' sh "$@"
fi
exec "$@"
