#!/usr/bin/env bash
# Fails (exit 1) listing every tracked C++ file whose formatting differs from .clang-format.
set -u
clang_format=$1
root=$2
cd "$root" || exit 2
status=0
while IFS= read -r f; do
  if ! "$clang_format" --dry-run --Werror "$f" >/dev/null 2>&1; then
    echo "format: $f differs from .clang-format (run: clang-format -i $f)"
    status=1
  fi
done < <(find core drivers agent tools tests lcm_types -name '*.cpp' -o -name '*.hpp' 2>/dev/null | sort)
[ $status -eq 0 ] && echo "format: all files clean"
exit $status
