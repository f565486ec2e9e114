set datafile separator ','
set terminal png size 900,600
set output 'docs/benchmarks/paper/trel.png'
set termoption noenhanced
set logscale x
set xlabel 'N'
set ylabel 'T_rel = T / T(mono, linked cell)'
set key top left
set yrange [0:*]
set title 'DEM time relative to monodisperse (seed Fig. 2.6), packing 0.6'
plot 'docs/benchmarks/paper/trel.csv' using (strcol(1) eq 'bi omega=10' ? $2 : 1/0):10 with linespoints lw 2 title 'bi omega=10', 'docs/benchmarks/paper/trel.csv' using (strcol(1) eq 'mono' ? $2 : 1/0):10 with linespoints lw 2 title 'mono', 'docs/benchmarks/paper/trel.csv' using (strcol(1) eq 'uniform-volume omega=10' ? $2 : 1/0):10 with linespoints lw 2 title 'uniform-volume omega=10', 'docs/benchmarks/paper/trel.csv' using (strcol(1) eq 'uniform-volume omega=50' ? $2 : 1/0):10 with linespoints lw 2 title 'uniform-volume omega=50', 'docs/benchmarks/paper/trel.csv' using (strcol(1) eq 'uniform-volume omega=50 (walls)' ? $2 : 1/0):10 with linespoints lw 2 title 'uniform-volume omega=50 (walls)'
