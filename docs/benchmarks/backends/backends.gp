set terminal png size 1200,650
set output 'docs/benchmarks/backends/backends.png'
set termoption noenhanced
set style data histograms
set style histogram clustered gap 1
set style fill solid 0.8 border -1
set logscale y
set ylabel 'microseconds per particle (build + findPairs)'
set xtics rotate by -30
set key outside right
set title 'Broad phases side by side (N = 50000)'
plot for [col=2:8] 'docs/benchmarks/backends/backends_matrix.dat' using col:xtic(1) title columnheader
