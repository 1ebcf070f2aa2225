set terminal pngcairo size 960,960 enhanced font 'DejaVu Sans,10'
if (!exists('rbc_output')) rbc_output = 'corner.png'
set output rbc_output
set datafile separator ','
set datafile commentschars '#'
set multiplot layout 3,3 title 'posterior (continuum p2 E2000, 500 samples)'
unset key
set grid
set format x '%.3g'
set format y '%.3g'
set xtics rotate by 30 right
set xlabel ''
set xrange [7.21082:32.5778]
set ylabel 'density'
set autoscale y
plot 'corner_marginals.csv' skip 1 using 1:2 with boxes fs solid 0.5 lc rgb '#1f77b4'
set multiplot next
set multiplot next
set xlabel ''
set xrange [7.21082:32.5778]
set ylabel 'lmax (nm)'
set yrange [150.029:282.429]
plot 'posterior_samples.csv' skip 1 using 1:2 with points pt 7 ps 0.25 lc rgb '#1f77b4'
set xlabel ''
set xrange [150.029:282.429]
set ylabel ''
set autoscale y
plot 'corner_marginals.csv' skip 1 using 3:4 with boxes fs solid 0.5 lc rgb '#1f77b4'
set multiplot next
set xlabel 'persistence (nm)'
set xrange [7.21082:32.5778]
set ylabel 'sigma-scale'
set yrange [0.456959:1.21916]
plot 'posterior_samples.csv' skip 1 using 1:3 with points pt 7 ps 0.25 lc rgb '#1f77b4'
set xlabel 'lmax (nm)'
set xrange [150.029:282.429]
set ylabel ''
set yrange [0.456959:1.21916]
plot 'posterior_samples.csv' skip 1 using 2:3 with points pt 7 ps 0.25 lc rgb '#1f77b4'
set xlabel 'sigma-scale'
set xrange [0.456959:1.21916]
set ylabel ''
set autoscale y
plot 'corner_marginals.csv' skip 1 using 5:6 with boxes fs solid 0.5 lc rgb '#1f77b4'
unset multiplot
set output
