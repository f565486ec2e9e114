set datafile separator ','
set terminal png size 900,600
set output 'docs/benchmarks/paper/model.png'
set termoption noenhanced
set logscale xy
set xlabel 'model T/N (pair tests + K cell accesses)'
set ylabel 'measured us per particle'
set key top left
set title 'Cost model vs measurement, power laws (Krijgsman et al. 2014, thesis 2.2.5)'
plot 'docs/benchmarks/paper/model.csv' using (strcol(6) eq 'top-down optimal' ? $8 : 1/0):14 with points pt 5 ps 1.5 title 'top-down optimal', 'docs/benchmarks/paper/model.csv' using (strcol(6) eq 'bottom-up optimal' ? $8 : 1/0):14 with points pt 7 ps 1.5 title 'bottom-up optimal', 'docs/benchmarks/paper/model.csv' using (strcol(6) eq 'top-down constant m' ? $8 : 1/0):14 with points pt 9 ps 1.5 title 'top-down constant m', 'docs/benchmarks/paper/model.csv' using (strcol(6) eq 'linked cell' ? $8 : 1/0):14 with points pt 11 ps 1.5 title 'linked cell'
