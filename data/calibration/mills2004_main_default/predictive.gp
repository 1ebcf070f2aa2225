set terminal pngcairo size 1100,700 enhanced font 'DejaVu Sans,12'
set output '.predictive.png.partial-15951'
set datafile separator ','
set datafile commentschars '#'
set title 'Posterior predictive (continuum p2 E2000): median and 90 % band of the model'
set xlabel 'force (pN)'
set ylabel 'diameter (um)'
set key inside right center
set grid
plot 'predictive.csv' skip 1 using 1:2:4 with filledcurves fs transparent solid 0.25 noborder title 'D_A 90 % band' noenhanced lc rgb '#1f77b4', \
     'predictive.csv' skip 1 using 1:3 with lines title 'D_A median' noenhanced lc rgb '#1f77b4' lw 2 dt 1, \
     'predictive.csv' skip 1 using 1:8:9 with yerrorbars title 'D_A Mills 2004 (total sigma)' noenhanced lc rgb '#000000' pt 7, \
     'predictive.csv' skip 1 using 1:5:7 with filledcurves fs transparent solid 0.25 noborder title 'D_T 90 % band' noenhanced lc rgb '#d62728', \
     'predictive.csv' skip 1 using 1:6 with lines title 'D_T median' noenhanced lc rgb '#d62728' lw 2 dt 1, \
     'predictive.csv' skip 1 using 1:10:11 with yerrorbars title 'D_T Mills 2004 (total sigma)' noenhanced lc rgb '#555555' pt 5
set output
