"""The command-line tools of yamor, each a module with a console command.

| module | command | what it does |
|---|---|---|
| reproduce | yamor-reproduce | the thesis's figures (chapters 4, 6, 7); see tools/reproduce/README.md |
| learning_bench | yamor-learning-bench | every plugin and Powell variant on the quadruped, several seeds |
| generated_bench | yamor-generated-bench | learning on the problems yamor-cpg-build generates |
| lifelong_bench | yamor-lifelong-bench | yamor-lifelong on its scenarios: detection latency, recall, false alarms |
| film_bench | yamor-film-bench | the CPU a filmed Evaluate costs through a real yamord |
| physics_compare | yamor-physics-compare | our world vs a naive ODE world vs MuJoCo |
| mujoco_eval | yamor-mujoco-eval | one exported robot in MuJoCo (run by physics_compare) |
| soak | yamor-soak | a bounded soak of one yamord (soak_client: its client processes) |
| plot_progress | yamor-plot-progress | an optimization's evaluations.csv (yamor-optimize's progress.png) |
| plot_landscape | yamor-plot-landscape | the grid plugin's landscape as a heatmap |
| plot_timeline | yamor-plot-timeline | a yamor-lifelong timeline like thesis Figure 7.4 |
| plot_setpoints | yamor-plot-setpoints | yamor-cpg-run's servo set-points |
| plot_characterize | yamor-plot-characterize | yamor-characterize's data as Figures B.1-B.19 |

`daemons` holds what the reproduction and the benchmarks share: a pool of
daemons (started with yamor.launcher, or running ones given by --hosts) and
yamor-optimize runs that stop cleanly. The tools find configs/ and build/ in
the checkout (yamor.checkout). The plot modules and mujoco_eval import
nothing of yamor: yamor-optimize and yamor-lifelong run plot_progress.py and
plot_timeline.py as scripts, physics_compare runs mujoco_eval.py in the
interpreter that has mujoco.
"""
