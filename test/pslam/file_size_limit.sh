#!/bin/sh
# file_size_limit.sh BLOCKS COMMAND...: runs COMMAND with files limited to BLOCKS x 512
# bytes (POSIX sh's ulimit -f unit), SIGXFSZ ignored, so a write beyond it fails with EFBIG
# as on a full disk instead of killing the process (an ignored signal survives exec).
trap '' XFSZ
ulimit -f "$1" || exit 125
shift
exec "$@"
