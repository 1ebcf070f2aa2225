set terminal pngcairo size 1400,700 enhanced font 'DejaVu Sans,12'
if (!exists('rbc_output')) rbc_output = 'accuracy_cost.png'
set output rbc_output
set datafile separator ','
set datafile commentschars '#'
set title 'Accuracy against cost, 13 forces of 0-193 pN'
set xlabel 'cost (energy+gradient evaluations of the N = 1,002 network)'
set ylabel 'largest relative error of D_{A}, D_{T} (%)'
set key below center horizontal
set grid
set key maxcols 4
set bmargin 8.8
set logscale x
set rmargin 6
set logscale y
set yrange [1e-2:10]
set arrow from graph 0, first 0.107994 to graph 1, first 0.107994 nohead dt 2 lc rgb '#777777'
set label 'reference spread (sd over rotations)' at graph 0.02, first 0.124193 tc rgb '#777777'
plot 'cost_continuum_full.csv' skip 1 using 1:($2*100) with linespoints title 'continuum full law' lc rgb '#1f77b4' pt 7 lw 2 dt 1, \
     'cost_continuum_full_loop.csv' skip 1 using 1:($2*100) with linespoints title 'Loop element, full law' lc rgb '#8c564b' pt 7 lw 2 dt 1, \
     'cost_continuum_full_loop_mirror.csv' skip 1 using 1:($2*100) with linespoints title 'Loop element, full law, mirror' lc rgb '#8c564b' pt 6 lw 2 dt 2, \
     'cost_continuum_full_mirror.csv' skip 1 using 1:($2*100) with linespoints title 'continuum full law, mirror' lc rgb '#1f77b4' pt 6 lw 2 dt 2, \
     'cost_continuum_full_refined1.csv' skip 1 using 1:($2*100) with linespoints title 'on-surface icosphere, full law' lc rgb '#d62728' pt 7 lw 2 dt 1, \
     'cost_continuum_full_refined1_mirror.csv' skip 1 using 1:($2*100) with linespoints title 'on-surface icosphere, full law, mirror' lc rgb '#d62728' pt 6 lw 2 dt 2, \
     'cost_continuum_p2.csv' skip 1 using 1:($2*100) with linespoints title 'continuum p = 2' lc rgb '#2ca02c' pt 7 lw 2 dt 1, \
     'cost_continuum_p2_mirror.csv' skip 1 using 1:($2*100) with linespoints title 'continuum p = 2, mirror' lc rgb '#2ca02c' pt 6 lw 2 dt 2, \
     'cost_discrete.csv' skip 1 using 1:($2*100) with linespoints title 'discrete' lc rgb '#ff7f0e' pt 7 lw 2 dt 1, \
     'cost_discrete_mirror.csv' skip 1 using 1:($2*100) with linespoints title 'discrete, mirror' lc rgb '#ff7f0e' pt 6 lw 2 dt 2
set output
