#!/bin/sh
# Charts of a results.csv (bench/run.sh): per accuracy problem its error
# against CPU time on log axes, one colour per method, the Pareto front
# (runs no other run beats in both cost and error) drawn as a line; the
# stability maps (outcome per time step x spacing, per solver and kernel,
# and per time step x wind at 2 km); and stability.csv, the measured
# envelope as a small table.
# Usage: sh bench/plot.sh results.csv outdir
set -eu
CSV=$1
OUT=$2
TMP=$(mktemp -d)
trap 'rm -rf "$TMP"' EXIT INT TERM

# A chart per entry: PROBLEM (its primary error, column 9) or
# PROBLEM:COLUMN:CHART (another error column of the same rows, drawn as
# CHART.png): the demo problems (demo, demo_36h_reffull, ...) get their
# thickness RMSE (column 11) and patch-centre error (13) charted too.
demos=$(awk -F, 'NR > 1 && $1 ~ /^demo/ { print $1 }' "$CSV" | sort -u)
extra=""
for d in $demos; do
    extra="$extra $d $d:11:${d}_hbar_rmse $d:13:${d}_patch_centre"
done
for entry in free_drift coast stefan disc plastic_wave r300 \
    auto_vs_full_error:11:auto_vs_full_hbar_rmse \
    auto_vs_full_error_same_dx:11:auto_vs_full_same_dx_hbar_rmse \
    auto_vs_full_packed_error:11:auto_vs_full_packed_hbar_rmse \
    auto_vs_full_packed_error_same_dx:11:auto_vs_full_packed_same_dx_hbar_rmse $extra; do
    src=${entry%%:*}
    col=9
    prob=$src
    case $entry in *:*:*) col=$(echo "$entry" | cut -d: -f2); prob=$(echo "$entry" | cut -d: -f3) ;; esac
    awk -F, -v s="$src" -v p="$prob" -v col="$col" 'NR > 1 && $1 == s && $7 == "ok" && $col != "" {
            e = $col + 0; if (e < 1e-16) e = 1e-16; c = $4 + 0; if (c < 1e-5) c = 1e-5;
            print $2, c, e, $3 > ("'"$TMP"'/" p "." $2 ".dat"); ylab = $(col - 1) }
        END { if (ylab != "") print ylab > ("'"$TMP"'/" p ".ylab") }' "$CSV"
    ls "$TMP/$prob".*.dat >/dev/null 2>&1 || continue
    # Pareto front over every method of the problem
    cat "$TMP/$prob".*.dat | sort -k2,2g -k3,3g |
        awk 'BEGIN { best = 1e300 } $3 < best { best = $3; print $2, $3 }' > "$TMP/$prob.pareto"
    ylab=$(cat "$TMP/$prob.ylab")
    {
        echo "set terminal pngcairo size 800,560 font ',10'"
        echo "set output '$OUT/$prob.png'"
        echo "set logscale xy"
        echo "set grid"
        echo "set key outside right top"
        echo "set title '$prob: error against CPU time (Pareto front: black line)' noenhanced"
        echo "set xlabel 'CPU time, s'"
        echo "set ylabel '$ylab' noenhanced"
        printf "plot "
        for f in "$TMP/$prob".*.dat; do
            m=$(basename "$f" .dat); m=${m#"$prob".}
            printf "'%s' using 2:3 with points pt 7 ps 1.2 title '%s' noenhanced, " "$f" "$m"
        done
        echo "'$TMP/$prob.pareto' using 1:2 with steps lw 2 lc rgb 'black' title 'Pareto front'"
    } > "$TMP/$prob.gp"
    gnuplot "$TMP/$prob.gp"
done

# stability.csv: the envelope as a table
awk -F, 'BEGIN { OFS = ","; print "solver_kernel,dx_m,wind_m_s,dt_s,outcome,model_hours,frac_outside_ellipse_or_limit" }
    NR > 1 && $1 == "stability" {
        split($3, kv, ";"); dt = kv[1]; dx = kv[2]; w = kv[3]
        sub("dt=", "", dt); sub("dx=", "", dx); sub("wind=", "", w)
        code = $9 + 0
        name = code == 0 ? "stable_converged" : code == 1 ? "stable_not_converged" : \
               code == 2 ? "failed_" $7 : code == 3 ? "failed_clumping" : \
               code == 4 ? "refused_explicit_limit" : "unfinished_cpu_cap"
        print $2, dx, w, dt, name, $11, $13 }' "$CSV" > "$OUT/stability.csv"

# stability maps: one panel per solver_kernel, dt (x) against dx (y) at 10 m/s
if [ "$(wc -l < "$OUT/stability.csv")" -gt 1 ]; then
    methods=$(awk -F, 'NR > 1 { print $1 }' "$OUT/stability.csv" | sort -u)
    n=$(echo "$methods" | wc -l)
    for kind in dx wind; do
        {
            echo "set terminal pngcairo size 1200,$(( (n + 2) / 3 * 300 + 60 )) font ',9'"
            echo "set output '$OUT/stability_$kind.png'"
            echo "set multiplot layout $(( (n + 2) / 3 )),3 title 'Outcome: 0 stable+converged (green), 1 not converged (yellow), 2 blow-up (red), 3 clumping (magenta), 4 refused (grey), 5 CPU cap (blue)'"
            echo "set palette defined (0 '#2ca02c', 1 '#ffdd33', 2 '#d62728', 3 '#e377c2', 4 '#aaaaaa', 5 '#1f77b4')"
            echo "set cbrange [0:5]"
            echo "unset colorbox"
            echo "set xtics ('1' 0, '10' 1, '60' 2, '300' 3, '1800' 4)"
            echo "set xrange [-0.5:4.5]"
            echo "set xlabel 'dt, s'"
            if [ $kind = dx ]; then
                echo "set ytics ('0.5 km' 0, '1 km' 1, '2 km' 2, '5 km' 3)"
                echo "set yrange [-0.5:3.5]"
            else
                echo "set ytics ('5 m/s' 0, '10 m/s' 1, '20 m/s' 2)"
                echo "set yrange [-0.5:2.5]"
            fi
            for m in $methods; do
                awk -F, -v m="$m" -v kind=$kind '
                    function di(d) { return d == 1 ? 0 : d == 10 ? 1 : d == 60 ? 2 : d == 300 ? 3 : 4 }
                    NR > 1 && $1 == m {
                        c = $5 ~ /^stable_conv/ ? 0 : $5 ~ /^stable_not/ ? 1 : $5 ~ /clumping/ ? 3 : \
                            $5 ~ /^failed/ ? 2 : $5 ~ /^refused/ ? 4 : 5
                        if (kind == "dx" && $3 == 10)
                            print di($4), ($2 == 500 ? 0 : $2 == 1000 ? 1 : $2 == 2000 ? 2 : 3), c
                        if (kind == "wind" && $2 == 2000 && m ~ /gaussian/)
                            print di($4), ($3 == 5 ? 0 : $3 == 10 ? 1 : 2), c
                    }' "$OUT/stability.csv" > "$TMP/st_$kind.$m.dat"
                if [ -s "$TMP/st_$kind.$m.dat" ]; then
                    echo "set title '$m' noenhanced"
                    echo "plot '$TMP/st_$kind.$m.dat' using 1:2:3 with points pt 5 ps 6 lc palette notitle, '' using 1:2:(sprintf('%d', \$3)) with labels notitle"
                fi
            done
            echo "unset multiplot"
        } > "$TMP/st_$kind.gp"
        gnuplot "$TMP/st_$kind.gp"
    done
fi
