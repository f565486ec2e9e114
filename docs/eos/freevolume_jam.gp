set terminal png size 900,600 noenhanced
set output 'docs/eos/freevolume_jam.png'
set datafile separator ','
set logscale x
set format x '1e%L'
set xrange [1e-12:1e-4]
set yrange [2.4:3.6]
set xlabel 'phi_J - nu (phi_J = final phi / (1 - 3/Z_final), Z_final = 1e12)'
set ylabel 'Z (1 - nu/phi_J)'
set key top right
set title 'free-volume law near jamming (Ogarko thesis Fig. 3.8): polydem jam, N = 1000, to Z = 1e12'
set arrow from 1e-9, graph 0 to 1e-9, graph 1 nohead dt 3 lc rgb 'gray40'
set label 'left of the dotted line: block phi (10 decimals) does not resolve the gap' at 1.2e-12, 2.45 font ',9' tc rgb 'gray40'
plot 3 with lines lw 2 lc rgb 'black' title 'd = 3', 3.03 with lines dt 2 lc rgb 'gray50' title '+-1%', 2.97 with lines dt 2 lc rgb 'gray50' notitle, 'docs/eos/jam12-mono-fv.csv' using 1:($3 > 0 ? $2 : 1/0) every ::1 with points pt 7 ps 0.35 lc rgb '#1f77b4' title 'mono, blocks (nu = block middle)', 'docs/eos/jam12-mono-fv.csv' using 1:($3 > 0 ? 1/0 : $2) every ::1 with points pt 1 ps 0.3 lc rgb '#1f77b4' notitle, 'docs/eos/jam12-mono-fixed.csv' using 3:6 every ::1 with points pt 5 ps 1.6 lc rgb '#1f77b4' title 'mono, fixed density (exact nu)', 'docs/eos/jam12-us2-fv.csv' using 1:($3 > 0 ? $2 : 1/0) every ::1 with points pt 7 ps 0.35 lc rgb '#d62728' title 'us2, blocks (nu = block middle)', 'docs/eos/jam12-us2-fv.csv' using 1:($3 > 0 ? 1/0 : $2) every ::1 with points pt 1 ps 0.3 lc rgb '#d62728' notitle, 'docs/eos/jam12-us2-fixed.csv' using 3:6 every ::1 with points pt 5 ps 1.6 lc rgb '#d62728' title 'us2, fixed density (exact nu)'
