#!/usr/bin/env bash
# Builds the API reference of include/ with Doxygen (docs/Doxyfile) into build-docs/html/
# and fails on any warning: an undocumented public class, function or member, or a broken
# Doxygen command. Not part of CI's path (.ci/run and scripts/test.sh do not call it).
# Needs doxygen (Debian: apt-get install doxygen), which scripts/install-deps.sh does not
# install.
set -euo pipefail
cd "$(dirname "$0")/.."

command -v doxygen >/dev/null || {
  echo "docs: doxygen not found (Debian: apt-get install doxygen)" >&2
  exit 1
}
rm -rf build-docs
mkdir -p build-docs
# Doxygen writes its warnings to build-docs/warnings.log (WARN_LOGFILE); anything on its
# stderr (an unknown configuration tag, say) counts as a warning too.
doxygen docs/Doxyfile 2>build-docs/doxygen.stderr
cat build-docs/warnings.log build-docs/doxygen.stderr >&2
if [[ -s build-docs/warnings.log || -s build-docs/doxygen.stderr ]]; then
  echo "docs: $(cat build-docs/warnings.log build-docs/doxygen.stderr | wc -l) warning line(s)" >&2
  exit 1
fi
echo "docs: build-docs/html/index.html"
