set datafile separator ','
set terminal png size 900,600
set output 'docs/benchmarks/paper/levels.png'
set termoption noenhanced
set logscale y
set xlabel 'number of levels L'
set ylabel 'slowdown factor'
set key top left
set title 'HGrid slowdown against L, measured vs cost models'
plot 'docs/benchmarks/paper/levels.csv' using (strcol(1) eq 'uniform-volume' ? $3 : 1/0):8 with linespoints lc 1 title 'uniform-volume measured', '' using (strcol(1) eq 'uniform-volume' ? $3 : 1/0):10 with lines dt 2 lc 1 title 'uniform-volume model eq. 2.35', '' using (strcol(1) eq 'uniform-volume' ? $3 : 1/0):9 with lines dt 3 lc 1 title 'uniform-volume model L(m+K)', 'docs/benchmarks/paper/levels.csv' using (strcol(1) eq 'uniform-radius' ? $3 : 1/0):8 with linespoints lc 2 title 'uniform-radius measured', '' using (strcol(1) eq 'uniform-radius' ? $3 : 1/0):10 with lines dt 2 lc 2 title 'uniform-radius model eq. 2.35', '' using (strcol(1) eq 'uniform-radius' ? $3 : 1/0):9 with lines dt 3 lc 2 title 'uniform-radius model L(m+K)'
