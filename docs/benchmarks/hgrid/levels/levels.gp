set datafile separator ','
set terminal png size 900,600
set output 'docs/benchmarks/hgrid/levels/levels.png'
set logscale y
set xlabel 'number of levels L'
set ylabel 'slowdown factor'
set key top left
set title 'HGrid slowdown against L (omega = 50), measured vs cost models'
plot 'docs/benchmarks/hgrid/levels/levels.csv' using (strcol(1) eq 'uniform-volume' ? $3 : 1/0):8 with linespoints title 'UV measured', '' using (strcol(1) eq 'uniform-volume' ? $3 : 1/0):10 with lines dt 2 title 'UV model eq. 2.35', '' using (strcol(1) eq 'uniform-volume' ? $3 : 1/0):9 with lines dt 3 title 'UV model L(m+K)', '' using (strcol(1) eq 'uniform-radius' ? $3 : 1/0):8 with linespoints title 'US measured', '' using (strcol(1) eq 'uniform-radius' ? $3 : 1/0):10 with lines dt 2 title 'US model eq. 2.35'
