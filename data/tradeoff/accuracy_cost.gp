set terminal pngcairo size 1100,700 enhanced font 'DejaVu Sans,12'
if (!exists('rbc_output')) rbc_output = 'accuracy_cost.png'
set output rbc_output
set datafile separator ','
set datafile commentschars '#'
set title 'Accuracy against cost, 13 Mills forces'
set xlabel 'cost (energy+gradient evaluations of the N = 1,002 network)'
set ylabel 'largest relative error of D_A, D_T'
set key outside right top
set grid
set logscale x
set logscale y
set yrange [1e-4:0.1]
set title noenhanced
set xlabel noenhanced
set ylabel noenhanced
set arrow from graph 0, first 0.00107994 to graph 1, first 0.00107994 nohead dt 2 lc rgb '#777777'
set label 'reference spread (sd over rotations)' at graph 0.02, first 0.00124193 noenhanced tc rgb '#777777'
plot 'cost_continuum_full.csv' skip 1 using 1:2 with linespoints title 'continuum full law' noenhanced lc rgb '#1f77b4' pt 7 lw 2 dt 1, \
     'cost_continuum_full_mirror.csv' skip 1 using 1:2 with linespoints title 'continuum full law, mirror' noenhanced lc rgb '#1f77b4' pt 6 lw 2 dt 2, \
     'cost_continuum_p2.csv' skip 1 using 1:2 with linespoints title 'continuum p = 2' noenhanced lc rgb '#2ca02c' pt 7 lw 2 dt 1, \
     'cost_continuum_p2_mirror.csv' skip 1 using 1:2 with linespoints title 'continuum p = 2, mirror' noenhanced lc rgb '#2ca02c' pt 6 lw 2 dt 2, \
     'cost_discrete.csv' skip 1 using 1:2 with linespoints title 'discrete' noenhanced lc rgb '#ff7f0e' pt 7 lw 2 dt 1, \
     'cost_discrete_mirror.csv' skip 1 using 1:2 with linespoints title 'discrete, mirror' noenhanced lc rgb '#ff7f0e' pt 6 lw 2 dt 2
set output
