#!/usr/bin/env bash
# Fails (exit 1) listing every tracked C++ file whose formatting differs from .clang-format.
# One clang-format process for all files (a process per file spent 30 s starting up).
set -u
clang_format=$1
root=$2
cd "$root" || exit 2
mapfile -t files < <(find core drivers agent tools tests lcm_types \( -name '*.cpp' -o -name '*.hpp' \) 2>/dev/null | sort)
[ ${#files[@]} -gt 0 ] || { echo "format: no C++ files found under $root"; exit 2; }
output=$("$clang_format" --dry-run --Werror "${files[@]}" 2>&1)
code=$?
# Violations read "FILE:LINE:COL: error: code should be clang-formatted [...]".
bad=$(printf '%s\n' "$output" | sed -n 's/^\([^:]*\):[0-9]*:[0-9]*: error: code should be clang-formatted.*/\1/p' | sort -u)
if [ -n "$bad" ]; then
  while IFS= read -r f; do echo "format: $f differs from .clang-format (run: clang-format -i $f)"; done <<<"$bad"
  exit 1
fi
if [ $code -ne 0 ]; then
  echo "format: clang-format failed:"
  printf '%s\n' "$output" | head -20
  exit 1
fi
echo "format: all files clean (${#files[@]} files)"
