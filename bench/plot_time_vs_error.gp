# The time-against-error plot of `lensfx bench time-vs-error`: one panel per lens, log ms per flare across,
# log relative L1 (32 px blocks) up; the Pareto front joined in green, the default red, high orange, fixed
# grids grey, the default with one acceleration off blue. Input: the CSV of --means (Debian: gnuplot-nox).
#   lensfx bench time-vs-error --from-csv docs/time-vs-error.csv --means /tmp/means.csv
#   gnuplot -c bench/plot_time_vs_error.gp /tmp/means.csv docs/images/time-vs-error.png
if (ARGC < 2) { print "usage: gnuplot -c bench/plot_time_vs_error.gp MEANS.csv OUT.png"; exit status 2 }
means = ARG1
lenses = system(sprintf("awk -F, 'NR > 1 && !seen[$1]++ { print $1 }' '%s'", means))
n = words(lenses)
set terminal pngcairo size 520 * n, 380 font ",9"
set output ARG2
set datafile separator ","
set logscale xy
set grid xtics ytics lc rgb "#dcdcdc"
set xlabel "ms per flare"
set ylabel "rel L1 (32 px blocks)"
set key off
set multiplot layout 1, n
colour(s) = s eq "default" ? 0xdc1414 : (s eq "high" ? 0xf08c00 : (s[1:4] eq "grid" ? 0x787878 : 0x285adc))
do for [i = 1:n] {
    lens = word(lenses, i)
    set title lens
    # the front: its points alone, sorted by time (a NaN between them would break the line)
    front = sprintf("< awk -F, '$1 == \"%s\" && $5 == 1' '%s' | sort -t, -k3 -g", lens, means)
    plot front using 3:4 with lines lc rgb "#009600" lw 2, \
         means using (strcol(1) eq lens ? $3 : NaN):4:(colour(strcol(2))) with points pt 7 ps 1 lc rgb variable, \
         means using (strcol(1) eq lens ? $3 : NaN):4:2:(colour(strcol(2))) with labels offset 1, 0.5 left font ",7" tc rgb variable
}
unset multiplot
