set terminal pngcairo size 960,960 enhanced font 'DejaVu Sans,10'
set output '.corner.png.tmp'
set datafile separator ','
set datafile commentschars '#'
set multiplot layout 3,3 title 'posterior (continuum p2 E2000, 500 samples)'
unset key
set grid
set xlabel ''
set xrange [8.50217:38.7451]
set ylabel 'density'
set autoscale y
plot 'corner_marginals.csv' skip 1 using 1:2 with boxes fs solid 0.5 lc rgb '#1f77b4'
set multiplot next
set multiplot next
set xlabel ''
set xrange [8.50217:38.7451]
set ylabel 'lmax (nm)'
set yrange [150.035:293.795]
plot 'posterior_samples.csv' skip 1 using 1:2 with points pt 7 ps 0.25 lc rgb '#1f77b4'
set xlabel ''
set xrange [150.035:293.795]
set ylabel ''
set autoscale y
plot 'corner_marginals.csv' skip 1 using 3:4 with boxes fs solid 0.5 lc rgb '#1f77b4'
set multiplot next
set xlabel 'persistence (nm)'
set xrange [8.50217:38.7451]
set ylabel 'sigma-scale'
set yrange [0.608082:1.42476]
plot 'posterior_samples.csv' skip 1 using 1:3 with points pt 7 ps 0.25 lc rgb '#1f77b4'
set xlabel 'lmax (nm)'
set xrange [150.035:293.795]
set ylabel ''
set yrange [0.608082:1.42476]
plot 'posterior_samples.csv' skip 1 using 2:3 with points pt 7 ps 0.25 lc rgb '#1f77b4'
set xlabel 'sigma-scale'
set xrange [0.608082:1.42476]
set ylabel ''
set autoscale y
plot 'corner_marginals.csv' skip 1 using 5:6 with boxes fs solid 0.5 lc rgb '#1f77b4'
unset multiplot
set output
