#!/bin/bash
# Installs the build tree into a temporary prefix and runs the installed lensfx on a sample frame: the
# program, its OpenImageIO module (loaded from PREFIX/lib/lensfx), the presets, the man page and the bash
# completion must all be there and work. Usage: test_install.sh BUILD_DIR SOURCE_DIR
set -euo pipefail
build=$1
src=$2
prefix=$(mktemp -d /tmp/lensfx-install-XXXXXX)
trap 'rm -rf "$prefix"' EXIT
fail() { echo "install test: $*" >&2; exit 1; }

cmake --install "$build" --prefix "$prefix" > "$prefix/install.log" || fail "cmake --install failed: $(cat "$prefix/install.log")"
for f in bin/lensfx lib/lensfx/liblensfx_oiio.so share/man/man1/lensfx.1 share/bash-completion/completions/lensfx \
         share/zsh/site-functions/_lensfx share/lensfx/presets/lenses/cooke-triplet.toml share/lensfx/presets/looks; do
    [ -e "$prefix/$f" ] || fail "$f is not installed"
done

"$prefix/bin/lensfx" --version | grep -q "OpenImageIO" || fail "--version does not name the libraries"

# A sample frame through the installed program, flared, to a PNG: the module must come from the prefix.
frame=$(ls "$src"/samples/pan/*.exr | head -n 1)
LD_DEBUG=files "$prefix/bin/lensfx" -q -i "$frame" -o "$prefix/out.png" --lens cooke-triplet --grid 16 2> "$prefix/ld.log" \
    || fail "the installed lensfx failed: $(grep -v '^ *[0-9]*:' "$prefix/ld.log")"
[ -s "$prefix/out.png" ] || fail "no output"
grep -q "file=$prefix/lib/lensfx/liblensfx_oiio.so" "$prefix/ld.log" \
    || fail "liblensfx_oiio.so was not loaded from $prefix/lib/lensfx: $(grep liblensfx_oiio "$prefix/ld.log" | head -n 3)"

# The man page holds every command's help.
for text in '^\.TH LENSFX 1' '^\.SS lensfx flare' '^\.SS lensfx lens trace' '\\-\\-stream\\-format' '^\.SH EXIT STATUS'; do
    grep -q -- "$text" "$prefix/share/man/man1/lensfx.1" || fail "the man page lacks $text"
done

# Bash completion offers options and commands from the installed program's help.
export PATH="$prefix/bin:$PATH"
source "$prefix/share/bash-completion/completions/lensfx"
COMP_WORDS=(lensfx --stream-f); COMP_CWORD=1; _lensfx
[[ " ${COMPREPLY[*]} " == *" --stream-format "* ]] || fail "bash completion of --stream-f gave: ${COMPREPLY[*]}"
COMP_WORDS=(lensfx fl); COMP_CWORD=1; _lensfx
[[ " ${COMPREPLY[*]} " == *" flare "* ]] || fail "bash completion of fl gave: ${COMPREPLY[*]}"
COMP_WORDS=(lensfx flare --ang); COMP_CWORD=2; _lensfx
[[ " ${COMPREPLY[*]} " == *" --angle "* ]] || fail "bash completion of flare --ang gave: ${COMPREPLY[*]}"
echo "install test: passed ($prefix)"
