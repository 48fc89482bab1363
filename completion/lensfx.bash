# bash completion for lensfx: commands and options as the program's own --help lists them, files otherwise.
_lensfx() {
    local cur prev words cword
    _init_completion 2>/dev/null || { cur="${COMP_WORDS[COMP_CWORD]}"; prev="${COMP_WORDS[COMP_CWORD-1]}"; words=("${COMP_WORDS[@]}"); cword=$COMP_CWORD; }
    local prog="${words[0]}" cmd=() w
    for w in "${words[@]:1:cword-1}"; do
        case "$w" in
            lens|gpu|flare|track|bench|info|trace|list|convert|time-vs-error) cmd+=("$w") ;;
        esac
    done
    local help
    help=$("$prog" "${cmd[@]}" --help 2>/dev/null)
    if [[ "$cur" == -* ]]; then
        COMPREPLY=($(compgen -W "$(grep -oE -- '(^|[ ,])--?[A-Za-z][A-Za-z0-9-]*' <<<"$help" | tr -d ' ,' | sort -u)" -- "$cur"))
        return
    fi
    local subs
    subs=$(awk '/^Subcommands:/{on=1; next} on && /^  [a-z]/{print $1} on && !/^ /{on=0}' <<<"$help")
    if [[ -n "$subs" && "$prev" != -* ]]; then
        COMPREPLY=($(compgen -W "$subs" -- "$cur"))
        [[ ${#COMPREPLY[@]} -gt 0 ]] && return
    fi
    COMPREPLY=($(compgen -f -- "$cur"))
}
complete -o filenames -F _lensfx lensfx
