# Writes the lensfx(1) man page from the program's own help: `lensfx --help`, then `lensfx CMD --help` for
# each command it lists (and their own commands). The sections around the help (streams, environment,
# exit status) are written here: this file is the man page's source.
# Run as: cmake -DLENSFX=path/to/lensfx -DOUT=lensfx.1 -DVERSION=x.y.z -P man_page.cmake

# `lensfx ARGS --help` as text; fails the build when the program cannot print it.
function(lensfx_help out_var)
  execute_process(COMMAND ${LENSFX} ${ARGN} --help OUTPUT_VARIABLE text RESULT_VARIABLE failed ERROR_VARIABLE err)
  if(failed)
    message(FATAL_ERROR "${LENSFX} ${ARGN} --help failed: ${err}")
  endif()
  set(${out_var} "${text}" PARENT_SCOPE)
endfunction()

# The names listed under "Subcommands:" in a help text.
function(subcommands_of text out_var)
  set(names "")
  string(REPLACE ";" "," text "${text}")
  string(REPLACE "\n" ";" lines "${text}")
  set(in_list OFF)
  foreach(line IN LISTS lines)
    if(line MATCHES "^Subcommands:")
      set(in_list ON)
    elseif(in_list AND line MATCHES "^  ([a-z][a-z0-9-]*)")
      list(APPEND names "${CMAKE_MATCH_1}")
    elseif(in_list AND NOT line MATCHES "^ ")
      set(in_list OFF)
    endif()
  endforeach()
  set(${out_var} "${names}" PARENT_SCOPE)
endfunction()

# Help text as a preformatted roff block: backslashes and hyphens escaped, no line read as a request.
function(roff_block text out_var)
  string(REPLACE "\\" "\\e" text "${text}")
  string(REPLACE "-" "\\-" text "${text}")
  string(REGEX REPLACE "(^|\n)([.'])" "\\1\\\\&\\2" text "${text}")
  set(${out_var} ".nf\n${text}\n.fi\n" PARENT_SCOPE)
endfunction()

lensfx_help(main)
roff_block("${main}" main_roff)
set(page ".TH LENSFX 1 \"\" \"lensfx ${VERSION}\" \"User Commands\"
.SH NAME
lensfx \\- physically based lens flare for HDR frames and streams
.SH SYNOPSIS
.B lensfx
\\-i IN \\-o OUT [options]
.br
.B lensfx
COMMAND [options]
.SH DESCRIPTION
lensfx finds the bright lights of each HDR frame, traces ray bundles through a real lens prescription on
the GPU, adds the ghosts and the diffraction starburst in scene\\-linear light, and tone maps with
OpenColorIO. Only R, G and B change: every other channel, the windows and the metadata pass through.
A luminance\\-only image (channel Y, or Y and A) is flared as grey (R = G = B = Y) and written back as Y,
the luminance of the coloured flare; luminance/chroma images (Y, RY, BY) are refused.
.SH OPTIONS
${main_roff}")

subcommands_of("${main}" commands)
if(commands)
  string(APPEND page ".SH COMMANDS\n")
endif()
foreach(cmd IN LISTS commands)
  lensfx_help(help ${cmd})
  roff_block("${help}" help_roff)
  string(APPEND page ".SS lensfx ${cmd}\n${help_roff}")
  subcommands_of("${help}" inner)
  foreach(sub IN LISTS inner)
    lensfx_help(sub_help ${cmd} ${sub})
    roff_block("${sub_help}" sub_roff)
    string(APPEND page ".SS lensfx ${cmd} ${sub}\n${sub_roff}")
  endforeach()
endforeach()

string(APPEND page ".SH STREAMS
\\fB\\-i \\-\\fR reads a stream of EXR or PFM images from stdin, told apart by their magic number (raw
planar float with \\fB\\-\\-pix\\-fmt\\fR and \\fB\\-\\-size\\fR). \\fB\\-o \\-\\fR writes the input stream's
format, EXR for file inputs, or what \\fB\\-\\-stream\\-format exr|pfm|raw\\fR says (raw with
\\fB\\-\\-pix\\-fmt gbrpf32le|gbrapf32le\\fR). EXR streams keep alpha and every value. ffmpeg writes
an EXR stream with \\fB\\-f image2pipe \\-c:v exr \\-\\fR and reads lensfx's output as
\\fB\\-f rawvideo \\-pix_fmt gbrapf32le \\-s WxH \\-framerate N \\-i \\-\\fR. Do not pipe RGBA frames
through ffmpeg's PFM encoder: it converts them through [0,1] and every highlight is lost.
.SH FILES
.TP
.I PREFIX/lib/lensfx/liblensfx_oiio.so
OpenImageIO's formats (TIFF, HDR, PNG, JPEG...), loaded on first use.
.TP
.I PREFIX/share/lensfx/presets
The lens presets and flare looks (the presets are also built into the program).
.SH ENVIRONMENT
.TP
.B OCIO
The OpenColorIO config, unless \\fB\\-\\-ocio\\fR is given; without either, a built\\-in ACES config.
.TP
.B LENSFX_CACHE_DIR
Where start\\-up tables are cached (default ~/.cache/lensfx; \\fBnone\\fR: no cache).
.SH EXIT STATUS
0 on success, 1 when a run fails, 2 for a usage error (unknown option, bad value); the reason is one
line on stderr starting with \"lensfx:\".
.SH SEE ALSO
ffmpeg(1), oiiotool(1), ociocheck(1)
")
file(WRITE "${OUT}" "${page}")
