set terminal png size 900,600
set output 'docs/eos/eos_us100.png'
set datafile separator ','
set logscale y
set xlabel 'packing fraction nu'
set ylabel 'Z = pV/(N kT)'
set key top left
set title 'polydem jam, us100 (N = 4096): O1 = 0.673333, O2 = 0.598577'
o1 = 0.673333; o2 = 0.598577; pj = 0.66921060
bm(x) = 1/(1-x) + o1*3*x/(1-x)**2 + o2*x**2*(3-x)/(1-x)**3
scs(x) = bm(x) + (o1-o2)*x**3/(1-x)**3
bcsk(x) = bm(x) + o2*x**3*(1-2*x)/(3*(1-x)**3)
ol(x) = (scs(x) + bcsk(x))/2
cs(x) = (1 + x + x**2 - x**3)/(1-x)**3
fv(x) = x < pj ? 3/(1 - x/pj) : 1/0
set xrange [0.3:pj + 0.005]
set yrange [3:1e5]
set samples 400
plot p = NaN, 'docs/eos/us100-fast.csv' using (q = p, p = $1, (q + $1)/2):2 with points pt 7 ps 0.4 title 'measured, schedule 1e-3', p = NaN, 'docs/eos/us100-slow.csv' using (q = p, p = $1, (q + $1)/2):2 with points pt 5 ps 0.4 title 'measured, schedule 5e-4:1e4;2e-4', bm(x) with lines lw 2 title 'Z_{BMCSL}', ol(x) with lines lw 2 dt 2 title 'Z_{OL}', \
  cs(x) with lines dt 3 title 'Z_{CS} (monodisperse)', fv(x) with lines dt 4 title sprintf('free volume 3/(1 - nu/%.4f)', pj)
