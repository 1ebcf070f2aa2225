set terminal pngcairo size 1400,700 enhanced font 'DejaVu Sans,12'
if (!exists('rbc_output')) rbc_output = 'accuracy_resolution.png'
set output rbc_output
set datafile separator ','
set datafile commentschars '#'
set title 'Error against resolution, 13 forces of 0-193 pN'
set xlabel 'mesh vertices (network: junction complexes; continuum: element corners)'
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
plot 'resolution_continuum_full.csv' skip 1 using 1:($2*100) with linespoints title 'continuum full law' lc rgb '#1f77b4' pt 7 lw 2 dt 1, \
     'spread_continuum_full.csv' skip 1 using 1:($3*100) with linespoints title 'continuum full law rotation spread (sd)' lc rgb '#1f77b4' pt 6 lw 2 dt 2, \
     'resolution_continuum_full_loop.csv' skip 1 using 1:($2*100) with linespoints title 'Loop element, full law' lc rgb '#8c564b' pt 7 lw 2 dt 1, \
     'spread_continuum_full_loop.csv' skip 1 using 1:($3*100) with linespoints title 'Loop element, full law rotation spread (sd)' lc rgb '#8c564b' pt 6 lw 2 dt 2, \
     'resolution_continuum_full_refined1.csv' skip 1 using 1:($2*100) with linespoints title 'on-surface icosphere, full law' lc rgb '#d62728' pt 7 lw 2 dt 1, \
     'spread_continuum_full_refined1.csv' skip 1 using 1:($3*100) with linespoints title 'on-surface icosphere, full law rotation spread (sd)' lc rgb '#d62728' pt 6 lw 2 dt 2, \
     'resolution_continuum_p2.csv' skip 1 using 1:($2*100) with linespoints title 'continuum p = 2' lc rgb '#2ca02c' pt 7 lw 2 dt 1, \
     'spread_continuum_p2.csv' skip 1 using 1:($3*100) with linespoints title 'continuum p = 2 rotation spread (sd)' lc rgb '#2ca02c' pt 6 lw 2 dt 2, \
     'resolution_discrete.csv' skip 1 using 1:($2*100) with linespoints title 'discrete' lc rgb '#ff7f0e' pt 7 lw 2 dt 1, \
     'spread_discrete.csv' skip 1 using 1:($3*100) with linespoints title 'discrete rotation spread (sd)' lc rgb '#ff7f0e' pt 6 lw 2 dt 2
set output
