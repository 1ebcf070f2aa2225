# SPDX-License-Identifier: GPL-3.0-or-later
# Thermal moduli of the periodic cell against the zero-temperature Gamma limit:
#   gnuplot docs/_static/thermal_moduli.gp   (from the repository root; reads thermal_moduli.csv)
set datafile separator ","
set terminal pngcairo size 1200,480 font "Sans,11"
set output "docs/_static/thermal_moduli.png"
csv = "docs/_static/thermal_moduli.csv"
set multiplot layout 1,2
set key top left
set xlabel "sampling temperature T (K)"
set xrange [-10:330]
set grid
# relative shift, %: columns 12/13 (mu), 14/15 (K); quasi-harmonic: 10/8 and 11/9
hex(c) = (strcol(1) eq "hex") ? column(c) : NaN
dis(c) = (strcol(1) eq "disordered") ? column(c) : NaN
set title "shear modulus: mu(T) / mu_{Gamma} - 1"
set ylabel "relative shift (%)"
plot csv skip 2 using 2:(100*hex(12)):(100*hex(13)) with yerrorbars pt 7 lc rgb "#1f77b4" title "hexagonal, sampled", \
     csv skip 2 using ($2+4):(100*dis(12)):(100*dis(13)) with yerrorbars pt 5 lc rgb "#d62728" title "disordered (X = 0.5), sampled", \
     csv skip 2 using 2:(100*(hex(10)/hex(8)-1)) with lines lw 2 dt 2 lc rgb "#1f77b4" title "hexagonal, quasi-harmonic O(T)", \
     csv skip 2 using 2:(100*(dis(10)/dis(8)-1)) with lines lw 2 dt 3 lc rgb "#d62728" title "disordered, quasi-harmonic O(T)", \
     0 with lines lc rgb "black" title "Gamma limit (T = 0)"
set title "area modulus: K(T) / K_{Gamma} - 1"
plot csv skip 2 using 2:(100*hex(14)):(100*hex(15)) with yerrorbars pt 7 lc rgb "#1f77b4" title "hexagonal, sampled", \
     csv skip 2 using ($2+4):(100*dis(14)):(100*dis(15)) with yerrorbars pt 5 lc rgb "#d62728" title "disordered (X = 0.5), sampled", \
     csv skip 2 using 2:(100*(hex(11)/hex(9)-1)) with lines lw 2 dt 2 lc rgb "#1f77b4" title "hexagonal, quasi-harmonic O(T)", \
     csv skip 2 using 2:(100*(dis(11)/dis(9)-1)) with lines lw 2 dt 3 lc rgb "#d62728" title "disordered, quasi-harmonic O(T)", \
     0 with lines lc rgb "black" title "Gamma limit (T = 0)"
unset multiplot
