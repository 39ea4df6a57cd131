#!/bin/bash
# One prepared session on a GPU machine (minutes of device time): run from the repository root.
#
#   OUT=/some/folder bash benchmarks/gpu_session.sh            # default steps
#   OUT=/some/folder bash benchmarks/gpu_session.sh coldstart pytest engine
#
# Steps (in the order given; each writes under $OUT, default out/gpu_session, and a cut-off
# call keeps what the earlier steps wrote):
#   coldstart  benchmarks/cuda_coldstart.py twice (compile, then numba's kernel cache)
#   pytest     the opt-in GPU tests (pytest -m gpu)
#   engine     benchmarks/engine.py's CUDA cases: the woodpile bed at 1k, 10k, 100k stalks and
#              16 worlds of the 1k bed, without and with JKR (issue 7's GPU targets)
#   paper      gpu_check.py's paper-fidelity stage (the factory fill, never run to its end on
#              a GPU) after its CPU/GPU check
#   study      gpu_check.py's study stage (the corn stalk's standard study, ~8 min on an H100)
#
# Uses the machine's python3 (numba-cuda there); a folder .whl/ of wheels (pydantic and what
# else the machine lacks) is installed to /tmp/site first when present. Measured steps and
# their times so far: benchmarks/README.md, "On a GPU".
set -u
cd "$(dirname "$0")/.."
OUT=${OUT:-out/gpu_session}
mkdir -p "$OUT"
T0=$(date +%s)
if ls .whl/*.whl >/dev/null 2>&1; then
  python3 -m pip install -q --no-index --no-deps --no-compile --no-cache-dir --upgrade \
    --target /tmp/site .whl/*.whl || exit 1
  export PYTHONPATH=$PWD/src:/tmp/site
else
  export PYTHONPATH=$PWD/src
fi
export PYTHONUNBUFFERED=1
nvidia-smi --query-gpu=name,driver_version,clocks.sm,clocks.max.sm --format=csv | tee "$OUT/gpu.txt"
python3 -c "import numba, numba_cuda, numpy; print('numba', numba.__version__, 'numba-cuda',
numba_cuda.__version__, 'numpy', numpy.__version__)" | tee -a "$OUT/gpu.txt"
STEPS=${*:-coldstart pytest engine paper}
for step in $STEPS; do
  echo "== $step at $(( $(date +%s) - T0 )) s"
  case $step in
    coldstart)
      python3 benchmarks/cuda_coldstart.py --json "$OUT/coldstart.json"
      python3 benchmarks/cuda_coldstart.py --json "$OUT/coldstart.json" ;;
    pytest)
      timeout 300 python3 -m pytest -v -m gpu -p no:cacheprovider tests 2>&1 \
        | tee "$OUT/pytest_gpu.txt" | tail -15 ;;
    engine)
      python3 benchmarks/engine.py --backends cuda --no-lammps --json "$OUT/engine_cuda.json" \
        2>&1 | tee "$OUT/engine_cuda.txt"
      python3 benchmarks/engine.py --backends cuda --no-lammps --cohesion 0.0002 \
        --json "$OUT/engine_cuda_jkr.json" 2>&1 | tee "$OUT/engine_cuda_jkr.txt" ;;
    paper)
      python3 benchmarks/gpu_check.py --stages check paper --json "$OUT/gpu_paper.json" \
        2>&1 | tee "$OUT/gpu_paper.txt" ;;
    study)
      python3 benchmarks/gpu_check.py --stages study --json "$OUT/gpu_study.json" \
        2>&1 | tee "$OUT/gpu_study.txt" ;;
    *) echo "unknown step $step (coldstart, pytest, engine, paper, study)"; exit 2 ;;
  esac
done
echo "== end at $(( $(date +%s) - T0 )) s"
