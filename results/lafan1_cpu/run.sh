#!/usr/bin/env bash
# The reproduction on a 2-core CPU: the commands that made results/lafan1_cpu, in order.
# Usage: bash results/lafan1_cpu/run.sh scratch|evaluate_scratch|finetune_scratch|late_prior|evaluate_late_prior|reconstruction_weight|from_skate512|evaluate_from_skate512|from_decay512|evaluate_from_decay512|either512|mixed_lengths|evaluate_mixed_lengths|from_mixed|evaluate_from_mixed|scratch_mixed|evaluate_scratch_mixed|scratch_mixed_none|from_scratch_mixed|
#        evaluate_scratch_mixed_none|evaluate_from_scratch_mixed|near32|near32_skate|near64|near64_more|evaluate_n64_more|
#        recon25_n64|best_of_n64|rho95_n64|rho95_best3_n64|evaluate_noise_correlation|horizon_n64|
#        evaluate_none_pair|frontier|prior25_n64|n64_more_none|evaluate_n64_more_none|prior_kl_n64|prior_kl_skate_n64|prior_kl_skate_n64_more|evaluate_prior_kl_skate|foot_motion_prior_kl|skate512_prior_kl|foot_velocity_prior_kl WEIGHT|prior_kl_velocity128|evaluate_velocity128|search_velocity128|velocity128_seed1|prior_fraction75_prior_kl|train|train_long|finetune|evaluate|evaluate_long|evaluate_finetune|figures
# (from the repository root)
set -euo pipefail
DATA=${DATA:-../shared/data/lafan1}
OUT=results/lafan1_cpu
# These runs were made when lafan1_cpu set these fields (it is the paper's loss with a validation split since
# 2026-12-04); every --config lafan1_cpu below passes them first, so later overrides still win:
CPU_BEFORE_PAPER="model.contact_input_gradient=true loss.kl_weight=0.1 loss.free_bits=1.0 loss.kl_warmup_steps=500"
CPU_BEFORE_PAPER="$CPU_BEFORE_PAPER loss.prior_sample_fraction=0.5 loss.foot_skate_weight=8.0 data.validation_files="
# The runs before "scratch" were made when lafan1_cpu had no prior samples and no foot-skate term:
BEFORE="loss.prior_sample_fraction=0 loss.foot_skate_weight=0"
# What the fine-tunes found, from step 0 in scratch_mixed (with a learning-rate decay: the config lafan1_cpu_mixed):
RECIPE="train.length_after_schedule=uniform loss.foot_skate_contacts=height_either loss.foot_skate_weight=128"
RECIPE="$RECIPE loss.foot_velocity_weight=16"
evaluate_runs() {  # evaluate_runs FOLDER RUN...: L = 30 and 50 at noise x0, x1 and x1.5 and where the error is
  # along the transition (results/error_frames.py, L = 30) for each runs/RUN, into $OUT/FOLDER
  local folder=$1; shift
  for run in "$@"; do
    bin/evaluate model --checkpoint runs/$run --data "$DATA" --samples 10 --lengths 30,50 --noise-scales 0,1.5 \
      --json $OUT/$folder/$run.json
    python results/error_frames.py --checkpoint runs/$run --data "$DATA" --length 30 \
      --out $OUT/$folder/error_frames_$run
  done
}
all_lengths() {  # all_lengths FOLDER RUN...: every length of the protocol at noise x1 and x0 for each runs/RUN,
  # into $OUT/FOLDER/RUN_all_lengths.json
  local folder=$1; shift
  for run in "$@"; do
    bin/evaluate model --checkpoint runs/$run --data "$DATA" --samples 10 --lengths 10,15,30,45,50 \
      --noise-scales 0 --json $OUT/$folder/${run}_all_lengths.json
  done
}
rho_ramp_all_lengths() {  # rho_ramp_all_lengths RUN...: every length with the latent noise correlated (0.95) and
  # ramped over 4 frames, at x1 and x2.5, for each runs/RUN, into $OUT/from_scratch_mixed/RUN_rho95_ramp4_all_lengths.json
  for run in "$@"; do
    bin/evaluate model --checkpoint runs/$run --data "$DATA" --samples 10 --lengths 10,15,30,45,50 \
      --noise-scales 2.5 --noise-correlation 0.95 --noise-ramp 4 \
      --json $OUT/from_scratch_mixed/${run}_rho95_ramp4_all_lengths.json
  done
}
fine_tune_lr() {  # fine_tune_lr FROM UNTIL: the fine-tunes' learning rate, 1e-4 decaying to 2.5e-5 from step FROM
  # to step UNTIL
  echo "train.learning_rate=1e-4 train.lr_decay_to=0.25 train.lr_decay_from_step=$1 train.lr_decay_until_step=$2"
}
prior_kl_pair_fine_tune() {  # the options of every 2400-step fine-tune of the committed prior-KL pair (step 30400
  # to 32800): the fine-tunes' learning rate, the recipe and the two frames next to each keyframe weighted at 64
  echo "--config lafan1_cpu $CPU_BEFORE_PAPER --data $DATA --no-progress --max-steps 32800 $(fine_tune_lr 30400 32800) $RECIPE" \
    "loss.near_keyframe_frames=2 loss.near_keyframe_weight=64"
}
case "${1:-}" in
  scratch)  # the reproduction from scratch with prior samples and the foot-skate term from step 0 (configs/lafan1_cpu.py),
    # "none" trained the same way, and from step 2000 the height-weighted foot-skate term; the three went side by
    # side on the same 2 cores at nice -n 10 (results/README.md, "From scratch"). The runs were stopped by
    # SIGTERM and resumed (same state: tests/train/test_train.py) to add the decay at the steps named here.
    DECAY="train.lr_decay_to=0.1 train.lr_decay_from_step=5000 train.lr_decay_until_step=8000"
    bin/train --config lafan1_cpu $CPU_BEFORE_PAPER --workdir runs/repro --data "$DATA" --no-progress --max-steps 8000 $DECAY &
    bin/train --config lafan1_cpu $CPU_BEFORE_PAPER --workdir runs/none --data "$DATA" --no-progress --max-steps 8000 $DECAY \
      model.posterior=none &
    until [ -d runs/repro/checkpoints/2000 ]; do sleep 10; done
    mkdir -p runs/base2000/checkpoints && cp -r runs/repro/checkpoints/2000 runs/base2000/checkpoints/
    bin/train --config lafan1_cpu $CPU_BEFORE_PAPER --init-from runs/base2000 --workdir runs/height32 --data "$DATA" --no-progress \
      --max-steps 8000 $DECAY loss.foot_skate_contacts=height loss.foot_skate_weight=32 &
    wait
    ;;
  evaluate_scratch)
    for run in repro height32 none; do  # every length, noise x0 / x0.5
      bin/evaluate model --checkpoint runs/$run --data "$DATA" --samples 10 --json $OUT/scratch/$run.json
    done
    for run in ${BEST:?} none repro; do  # the latent-pair search
      bin/evaluate model --checkpoint runs/$run --data "$DATA" --samples 10 --search 4 --noise-scales "" \
        --json $OUT/scratch/${run}_search4.json
    done
    for run in $BEST repro; do  # wider sampling
      bin/evaluate model --checkpoint runs/$run --data "$DATA" --samples 10 --lengths 30,50 --noise-scales 1.5,2 \
        --json $OUT/scratch/${run}_noise.json
    done
    python results/figures.py --checkpoint $OUT/scratch/models/$BEST --data "$DATA" --out $OUT/scratch/figures
    ;;
  finetune_scratch)  # fewer prior samples: two fine-tunes of height32 (step 8000) side by side at 0.3 x the
    # learning rate, stopped by SIGTERM after ~2000 steps (at steps 10036 and 10159), then evaluated
    FT="--config lafan1_cpu $CPU_BEFORE_PAPER --init-from runs/height32 --data $DATA --no-progress --max-steps 11000"
    LOSS="loss.foot_skate_contacts=height loss.foot_skate_weight=32"
    LR="train.lr_decay_to=0.3 train.lr_decay_from_step=8000 train.lr_decay_until_step=8001"
    bin/train $FT --workdir runs/h32_prior25 $LOSS $LR loss.prior_sample_fraction=0.25 &
    bin/train $FT --workdir runs/h32_prior50 $LOSS $LR &
    wait
    for run in h32_prior25 h32_prior50; do
      bin/evaluate model --checkpoint runs/$run --data "$DATA" --samples 10 --lengths 30,50 --noise-scales 0 \
        --json $OUT/scratch/$run.json
    done
    ;;
  late_prior)  # three fine-tunes of the reproduction model (step 8000) side by side at nice -n 10, to step 10500
    # (results/README.md, "Prior samples late, a stronger foot-skate term"): skate128 (foot-skate weight 128),
    # and two "late prior" runs that train on the posterior only (loss.prior_sample_fraction=0) to step 9500 and
    # with prior samples again from there. 0.3 x the learning rate to step 9500, then a linear decay to 0.1 x at
    # step 10500. The runs were stopped by SIGTERM at steps 8116-8119 and resumed with these step counts (same
    # state: tests/train/test_train.py); skate128 was stopped by SIGTERM just after step 9500 to add the decay.
    FT="--config lafan1_cpu $CPU_BEFORE_PAPER --data $DATA --no-progress"
    BASE=$OUT/scratch/models/height32
    LOSS="loss.foot_skate_contacts=height loss.foot_skate_weight=32"
    LR="train.lr_decay_to=0.3 train.lr_decay_from_step=8000 train.lr_decay_until_step=8001"
    DECAY="train.learning_rate=1.5e-4 train.lr_decay_to=0.3333 train.lr_decay_from_step=9500 train.lr_decay_until_step=10500"
    ( bin/train $FT --init-from $BASE --workdir runs/skate128 --max-steps 9500 $LOSS $LR loss.foot_skate_weight=128
      bin/train $FT --workdir runs/skate128 --max-steps 10500 $LOSS $DECAY loss.foot_skate_weight=128 ) &
    ( bin/train $FT --init-from $BASE --workdir runs/late_f0 --max-steps 9500 $LOSS $LR loss.prior_sample_fraction=0
      bin/train $FT --init-from runs/late_f0 --workdir runs/late --max-steps 10500 $LOSS $DECAY ) &
    ( bin/train $FT --init-from $BASE --workdir runs/late128_f0 --max-steps 9500 $LOSS $LR loss.prior_sample_fraction=0 \
        loss.foot_skate_weight=128
      bin/train $FT --init-from runs/late128_f0 --workdir runs/late128 --max-steps 10500 $LOSS $DECAY loss.foot_skate_weight=128 ) &
    wait
    ;;
  evaluate_late_prior)  # L = 30 and 50 at noise x0, x1 and x1.5 for each run; the control is scratch/h32_prior50.json
    for run in skate128 late late128; do
      bin/evaluate model --checkpoint runs/$run --data "$DATA" --samples 10 --lengths 30,50 --noise-scales 0,1.5 \
        --json $OUT/late_prior/$run.json
    done
    ;;
  reconstruction_weight)  # three continuations of late128 (step 10500) side by side at nice -n 10, to step 12500:
    # cont128 (nothing changes: the control), recon25 (loss.prior_sample_reconstruction_weight=0.25) and skate512
    # (foot-skate weight 512); 0.3 x the learning rate to step 11500, then a linear decay meant to reach 0.1 x at
    # 12500; all three were stopped by SIGTERM just after step 12000 (0.2 x there) to leave time to evaluate them
    FT="--config lafan1_cpu $CPU_BEFORE_PAPER --data $DATA --no-progress --init-from runs/late128 --max-steps 12500"
    LOSS="loss.foot_skate_contacts=height loss.foot_skate_weight=128"
    LR="train.learning_rate=1.5e-4 train.lr_decay_to=0.3333 train.lr_decay_from_step=11500 train.lr_decay_until_step=12500"
    bin/train $FT --workdir runs/cont128 $LOSS $LR &
    bin/train $FT --workdir runs/recon25 $LOSS $LR loss.prior_sample_reconstruction_weight=0.25 &
    bin/train $FT --workdir runs/skate512 $LOSS $LR loss.foot_skate_weight=512 &
    wait
    for run in cont128 recon25 skate512; do
      bin/evaluate model --checkpoint runs/$run --data "$DATA" --samples 10 --lengths 30,50 --noise-scales 0,1.5 \
        --json $OUT/late_prior/$run.json
    done
    ;;
  from_skate512)  # three continuations of late_prior/models/skate512 (step 12003) side by side at nice -n 10, each with
    # the learning rate decaying fully: from 1e-4 (0.2 x, where skate512 stopped) linearly to 0.05 x. decay512 changes
    # nothing else (the control); wide512 trains on the posterior alone (loss.prior_sample_fraction=0) to step 13500,
    # then with prior samples again at reconstruction weight 0.25; stitch512 raises the stitching weight to 2 (the
    # feet slid most inside the stitch overlap). Started with the decay to end at step 15000; stopped by SIGTERM at
    # steps 12895-12903 and resumed (same state: tests/train/test_train.py) with it ending at step 14500 instead, to leave
    # time to evaluate (the learning rate stepped from 0.78 to 0.73 x 1e-4 there).
    FT="--config lafan1_cpu $CPU_BEFORE_PAPER --data $DATA --no-progress"
    BASE=$OUT/late_prior/models/skate512
    LOSS="loss.foot_skate_contacts=height loss.foot_skate_weight=512"
    LR="train.learning_rate=1e-4 train.lr_decay_to=0.25 train.lr_decay_from_step=12003"
    FIRST="$LR train.lr_decay_until_step=15000"
    THEN="$LR train.lr_decay_until_step=14500"
    ( bin/train $FT --init-from $BASE --workdir runs/decay512 --max-steps 12895 $LOSS $FIRST
      bin/train $FT --workdir runs/decay512 --max-steps 14500 $LOSS $THEN ) &
    ( bin/train $FT --init-from $BASE --workdir runs/wide512_f0 --max-steps 12903 $LOSS $FIRST loss.prior_sample_fraction=0
      bin/train $FT --workdir runs/wide512_f0 --max-steps 13500 $LOSS $THEN loss.prior_sample_fraction=0
      bin/train $FT --init-from runs/wide512_f0 --workdir runs/wide512 --max-steps 14500 $LOSS $THEN \
        loss.prior_sample_reconstruction_weight=0.25 ) &
    ( bin/train $FT --init-from $BASE --workdir runs/stitch512 --max-steps 12902 $LOSS $FIRST loss.stitch_weight=2
      bin/train $FT --workdir runs/stitch512 --max-steps 14500 $LOSS $THEN loss.stitch_weight=2 ) &
    wait
    ;;
  evaluate_from_skate512)  # L = 30 and 50 at noise x0, x1 and x1.5 for each run; the control is late_prior/skate512.json;
    # then the noise ramp (results/noise_ramp.py) on skate512 and on the runs
    for run in decay512 stitch512 wide512; do
      bin/evaluate model --checkpoint runs/$run --data "$DATA" --samples 10 --lengths 30,50 --noise-scales 0,1.5 \
        --json $OUT/from_skate512/$run.json
    done
    python results/noise_ramp.py --checkpoint $OUT/late_prior/models/skate512 --data "$DATA" --ramps 0,4,8 \
      --noise-scales 1,1.5 --json $OUT/from_skate512/noise_ramp_skate512.json
    python results/noise_ramp.py --checkpoint runs/decay512 --data "$DATA" --ramps 4,8 --noise-scales 1,1.5 \
      --json $OUT/from_skate512/noise_ramp_decay512.json  # ramp 0 = decay512.json
    python results/foot_slide_frames.py --checkpoint $OUT/late_prior/models/skate512 --data "$DATA" --length 30 \
      --out $OUT/from_skate512/foot_slide_frames_skate512
    ;;
  from_decay512)  # three continuations of from_skate512/models/decay512 (step 14500) side by side at nice -n 10, each
    # with the learning rate from 5e-5 down to 2.5e-5 (where decay512 stopped) at step 16600. more512 changes nothing
    # (the control); keyvel512 gives both keyframes the transition's mean root velocity (model.keyframe_velocity=mean);
    # keyvel_wide512 was to do too, on the posterior alone to step 15500, then with prior samples at reconstruction
    # weight 0.25 (wide512's recipe); it was stopped at step 14962 for fvel32, which adds the foot velocity term
    # (loss.foot_velocity_weight=32: about the foot-skate term's share of the loss) once the feet were seen to jump in the first generated frame
    # (results/error_frames.py); fvel32 started 500 steps after the other two
    FT="--config lafan1_cpu $CPU_BEFORE_PAPER --data $DATA --no-progress"
    BASE=$OUT/from_skate512/models/decay512
    LOSS="loss.foot_skate_contacts=height loss.foot_skate_weight=512"
    LR="train.learning_rate=5e-5 train.lr_decay_to=0.5 train.lr_decay_from_step=14500 train.lr_decay_until_step=16600"
    bin/train $FT --init-from $BASE --workdir runs/more512 --max-steps 16600 $LOSS $LR &
    bin/train $FT --init-from $BASE --workdir runs/keyvel512 --max-steps 16600 $LOSS $LR model.keyframe_velocity=mean &
    bin/train $FT --init-from $BASE --workdir runs/fvel32 --max-steps 16600 $LOSS $LR loss.foot_velocity_weight=32 &
    wait
    ;;
  either512)  # decay512 continued as the runs above with the foot-skate term weighing a movement by the foot's height
    # at either end (loss.foot_skate_contacts=height_either), started alone after them and stopped by SIGTERM
    # (the step is in results/README.md), then evaluated as they were
    FT="--config lafan1_cpu $CPU_BEFORE_PAPER --data $DATA --no-progress"
    LR="train.learning_rate=5e-5 train.lr_decay_to=0.5 train.lr_decay_from_step=14500 train.lr_decay_until_step=16600"
    bin/train $FT --init-from $OUT/from_skate512/models/decay512 --workdir runs/either512 --max-steps 16600 $LR \
      loss.foot_skate_contacts=height_either loss.foot_skate_weight=512
    evaluate_runs from_decay512 either512
    ;;
  mixed_lengths)  # decay512 continued as from_decay512 above (same steps and learning rate), with each step's length
    # drawn uniformly from 5-50 (train.length_after_schedule=uniform; decay512 trained at L = 50 only since step
    # ~1500): the foot-skate term on height contacts (against more512), on either end (against either512), and
    # either end with the foot velocity term at 16; three side by side at nice -n 10
    FT="--config lafan1_cpu $CPU_BEFORE_PAPER --data $DATA --no-progress --init-from $OUT/from_skate512/models/decay512 --max-steps 16600"
    LR="train.learning_rate=5e-5 train.lr_decay_to=0.5 train.lr_decay_from_step=14500 train.lr_decay_until_step=16600"
    MIX="train.length_after_schedule=uniform loss.foot_skate_weight=512"
    bin/train $FT --workdir runs/mixed512 $LR $MIX loss.foot_skate_contacts=height &
    bin/train $FT --workdir runs/mixed_either512 $LR $MIX loss.foot_skate_contacts=height_either &
    bin/train $FT --workdir runs/mixed_either_fvel16 $LR $MIX loss.foot_skate_contacts=height_either \
      loss.foot_velocity_weight=16 &
    wait
    ;;
  from_mixed)  # three continuations of mixed_lengths/models/mixed_either_fvel16 (step 16600) side by side at
    # nice -n 10, to step 18400, the learning rate from 2.5e-5 (where it stopped) down to 1.25e-5: fv16_cont changes
    # nothing (the control); near8 weighs each direction's first two generated frames x8 in the state and FK terms
    # (loss.near_keyframe_weight: the last generated frame is what SLDE scores); recon25 scores the windows drawn
    # from the prior at reconstruction weight 0.25 (the samples spread more: late_prior/recon25)
    FT="--config lafan1_cpu $CPU_BEFORE_PAPER --data $DATA --no-progress --init-from $OUT/mixed_lengths/models/mixed_either_fvel16"
    FT="$FT --max-steps 18400"
    LR="train.learning_rate=2.5e-5 train.lr_decay_to=0.5 train.lr_decay_from_step=16600 train.lr_decay_until_step=18400"
    MIX="train.length_after_schedule=uniform loss.foot_skate_weight=512 loss.foot_skate_contacts=height_either"
    MIX="$MIX loss.foot_velocity_weight=16"
    bin/train $FT --workdir runs/fv16_cont $LR $MIX &
    bin/train $FT --workdir runs/near8 $LR $MIX loss.near_keyframe_weight=8 loss.near_keyframe_frames=2 &
    bin/train $FT --workdir runs/recon25_mixed $LR $MIX loss.prior_sample_reconstruction_weight=0.25 &
    wait
    ;;
  evaluate_from_mixed)  # as evaluate_mixed_lengths
    evaluate_runs from_mixed fv16_cont near8 recon25_mixed
    ;;
  scratch_mixed)  # lafan1_cpu from scratch with what the fine-tunes above found, from step 0: every length after the
    # schedule, the foot-skate term on either end's height at 128, the foot velocity term at 16; alone on the 2
    # cores (nice -n 10). Stopped by SIGTERM at step 4616 and resumed (same state: tests/train/test_train.py) with the
    # learning rate decaying from step 6000 to 0.05 x at 14000, to step 16000 (the config lafan1_cpu_mixed)
    RUN="--config lafan1_cpu $CPU_BEFORE_PAPER --workdir runs/scratch_mixed --data $DATA --no-progress --max-steps 16000"
    bin/train $RUN $RECIPE
    bin/train $RUN $RECIPE train.lr_decay_to=0.05 train.lr_decay_from_step=6000 train.lr_decay_until_step=14000
    ;;
  scratch_mixed_none)  # the same recipe with the posterior "none" (the paper's model: z from the prior heads at
    # training too), in one go (the learning-rate schedule is a function of the step), for the like-for-like
    # ablation; beside from_scratch_mixed on the same 2 cores (nice -n 10)
    bin/train --config lafan1_cpu $CPU_BEFORE_PAPER --workdir runs/scratch_mixed_none --data "$DATA" --no-progress --max-steps 16000 \
      $RECIPE train.lr_decay_to=0.05 train.lr_decay_from_step=6000 train.lr_decay_until_step=14000 model.posterior=none
    ;;
  from_scratch_mixed)  # three continuations of scratch_mixed/models/scratch_mixed (step 16000) to step 18400, side
    # by side with scratch_mixed_none (nice -n 10), the learning rate from 1e-4 down to 2.5e-5 (where
    # scratch_mixed stopped): sm_cont changes nothing (the control); sm_fb4 raises free bits from 1 to 4 nats per
    # frame (the posterior must carry more, to buy spread); sm_near8 weighs each direction's first two generated
    # frames x8 (SLDE)
    FT="--config lafan1_cpu $CPU_BEFORE_PAPER --data $DATA --no-progress --init-from $OUT/scratch_mixed/models/scratch_mixed"
    FT="$FT --max-steps 18400"
    LR=$(fine_tune_lr 16000 18400)
    bin/train $FT --workdir runs/sm_cont $LR $RECIPE &
    bin/train $FT --workdir runs/sm_fb4 $LR $RECIPE loss.free_bits=4 &
    bin/train $FT --workdir runs/sm_near8 $LR $RECIPE loss.near_keyframe_weight=8 loss.near_keyframe_frames=2 &
    wait
    ;;
  evaluate_scratch_mixed_none)  # as evaluate_scratch_mixed; then for it and scratch_mixed the latent-pair search at
    # every length, and L = 50 at noise x2-x8 (diversity at equal quality)
    evaluate_runs scratch_mixed scratch_mixed_none
    all_lengths scratch_mixed scratch_mixed_none
    for run in scratch_mixed scratch_mixed_none; do
      bin/evaluate model --checkpoint runs/$run --data "$DATA" --samples 10 --lengths 10,15,30,45,50 --search 4 \
        --noise-scales "" --json $OUT/scratch_mixed/${run}_search4.json
      bin/evaluate model --checkpoint runs/$run --data "$DATA" --samples 10 --lengths 50 --noise-scales 2,3,4,6,8 \
        --json $OUT/scratch_mixed/${run}_noise_sweep_L50.json
    done
    for scale in 1 6; do  # filmstrips at the paper's temperature and at the highest one still below interpolation
      python results/figures.py --checkpoint $OUT/scratch_mixed/models/scratch_mixed --data "$DATA" \
        --out $OUT/scratch_mixed/figures --no-notebook --noise-scale $scale
    done
    ;;
  near32)  # sm_near8 (step 18400) continued to step 20800 with the weight near the keyframes at 32, the same
    # learning-rate profile (1e-4 down to 2.5e-5); alone at nice -n 5 after a test run; then every length
    bin/train --config lafan1_cpu $CPU_BEFORE_PAPER --data "$DATA" --no-progress --init-from $OUT/from_scratch_mixed/models/sm_near8 \
      --max-steps 20800 --workdir runs/sm_near32 $(fine_tune_lr 18400 20800) $RECIPE loss.near_keyframe_weight=32 \
      loss.near_keyframe_frames=2
    all_lengths from_scratch_mixed sm_near32
    ;;
  near32_skate)  # runs/sm_near32 (step 20800, from near32) continued to step 23200, three side by side
    # (nice -n 10), the same learning-rate profile: n32_cont changes nothing (the control); n32_skate256 doubles
    # the foot-skate weight (foot slide at L = 45 / 50); n64_skate256 also doubles the weight near the keyframes
    # (SLDE at L = 45 / 50)
    FT="--config lafan1_cpu $CPU_BEFORE_PAPER --data $DATA --no-progress --init-from runs/sm_near32 --max-steps 23200"
    LR=$(fine_tune_lr 20800 23200)
    NEAR="loss.near_keyframe_frames=2 loss.near_keyframe_weight"
    bin/train $FT --workdir runs/n32_cont $LR $RECIPE $NEAR=32 &
    bin/train $FT --workdir runs/n32_skate256 $LR $RECIPE $NEAR=32 loss.foot_skate_weight=256 &
    bin/train $FT --workdir runs/n64_skate256 $LR $RECIPE $NEAR=64 loss.foot_skate_weight=256 &
    wait
    all_lengths from_scratch_mixed n32_cont n32_skate256 n64_skate256
    ;;
  near64)  # runs/n32_cont (step 23200, from near32_skate) continued to step 25600, two side by side
    # (nice -n 10), the same learning-rate profile: n32_cont2 changes nothing (the control); n64 doubles the
    # weight near the keyframes (SLDE at L = 45)
    FT="--config lafan1_cpu $CPU_BEFORE_PAPER --data $DATA --no-progress --init-from runs/n32_cont --max-steps 25600"
    LR=$(fine_tune_lr 23200 25600)
    NEAR="loss.near_keyframe_frames=2 loss.near_keyframe_weight"
    bin/train $FT --workdir runs/n32_cont2 $LR $RECIPE $NEAR=32 &
    bin/train $FT --workdir runs/n64 $LR $RECIPE $NEAR=64 &
    wait
    all_lengths from_scratch_mixed n32_cont2 n64
    ;;
  near64_more)  # runs/n64 (step 25600, from near64) continued to step 28000 with nothing changed, alone at
    # nice -n 5, the same learning-rate profile; then every length
    bin/train --config lafan1_cpu $CPU_BEFORE_PAPER --data "$DATA" --no-progress --init-from runs/n64 --max-steps 28000 \
      --workdir runs/n64_more $(fine_tune_lr 25600 28000) $RECIPE loss.near_keyframe_frames=2 \
      loss.near_keyframe_weight=64
    all_lengths from_scratch_mixed n64_more
    ;;
  evaluate_n64_more)  # the committed n64_more: L = 45 at two more sampling seeds, and L = 50 at noise x2-x8
    # (diversity at equal quality, as evaluate_scratch_mixed_none)
    M=$OUT/from_scratch_mixed/models/n64_more
    for seed in 1 2; do
      bin/evaluate model --checkpoint $M --data "$DATA" --samples 10 --lengths 45 --noise-scales "" --seed $seed \
        --json $OUT/from_scratch_mixed/n64_more_L45_seed$seed.json
    done
    bin/evaluate model --checkpoint $M --data "$DATA" --samples 10 --lengths 50 --noise-scales 2,3,4,6,8 \
      --json $OUT/from_scratch_mixed/n64_more_noise_sweep_L50.json
    bin/evaluate model --checkpoint $M --data "$DATA" --samples 10 --lengths 10,15,30,45,50 --noise-scales 2 \
      --json $OUT/from_scratch_mixed/n64_more_noise2_all_lengths.json
    for scale in 1 2; do  # filmstrips at the paper's temperature and at x2
      python results/figures.py --checkpoint $M --data "$DATA" --out $OUT/from_scratch_mixed/figures --no-notebook \
        --noise-scale $scale
    done
    ;;
  recon25_n64)  # the committed n64_more (step 28000) continued to step 30400 with the prior windows' state and FK
    # terms weighted 0.25 (spread), alone, the same learning-rate profile; then every length
    bin/train --config lafan1_cpu $CPU_BEFORE_PAPER --data "$DATA" --no-progress --init-from $OUT/from_scratch_mixed/models/n64_more \
      --max-steps 30400 --workdir runs/n64_recon25 $(fine_tune_lr 28000 30400) $RECIPE loss.near_keyframe_frames=2 \
      loss.near_keyframe_weight=64 loss.prior_sample_reconstruction_weight=0.25
    all_lengths from_scratch_mixed n64_recon25
    ;;
  best_of_n64)  # the committed n64_more (step 28000) continued to step 30400, two side by side at nice -n 10, the
    # same learning-rate profile: n64_cont changes nothing (the control), n64_best3 rolls each prior window out
    # three times and scores only the copy nearest the ground truth (loss.prior_best_of=3); then every length
    N64="--init-from $OUT/from_scratch_mixed/models/n64_more --max-steps 30400 $(fine_tune_lr 28000 30400) $RECIPE"
    N64="$N64 loss.near_keyframe_frames=2 loss.near_keyframe_weight=64"
    nice -n 10 bin/train --config lafan1_cpu $CPU_BEFORE_PAPER --data "$DATA" --no-progress --workdir runs/n64_cont $N64 &
    nice -n 10 bin/train --config lafan1_cpu $CPU_BEFORE_PAPER --data "$DATA" --no-progress --workdir runs/n64_best3 $N64 \
      loss.prior_best_of=3 &
    wait
    all_lengths from_scratch_mixed n64_cont n64_best3
    ;;
  rho95_n64)  # the committed n64_more (step 28000) continued to step 30400 with the latent noise correlated from
    # frame to frame at training and sampling (model.noise_correlation=0.95), the same learning-rate profile (the
    # control is best_of_n64's n64_cont); then every length
    bin/train --config lafan1_cpu $CPU_BEFORE_PAPER --data "$DATA" --no-progress --init-from $OUT/from_scratch_mixed/models/n64_more \
      --max-steps 30400 --workdir runs/n64_rho95 $(fine_tune_lr 28000 30400) $RECIPE loss.near_keyframe_frames=2 \
      loss.near_keyframe_weight=64 model.noise_correlation=0.95
    all_lengths from_scratch_mixed n64_rho95
    ;;
  rho95_best3_n64)  # rho95_n64 with each prior window rolled out three times, only the copy nearest the ground
    # truth scored by the state and FK terms (loss.prior_best_of=3); it went beside rho95_n64 (its control)
    bin/train --config lafan1_cpu $CPU_BEFORE_PAPER --data "$DATA" --no-progress --init-from $OUT/from_scratch_mixed/models/n64_more \
      --max-steps 30400 --workdir runs/n64_rho95_best3 $(fine_tune_lr 28000 30400) $RECIPE \
      loss.near_keyframe_frames=2 loss.near_keyframe_weight=64 model.noise_correlation=0.95 loss.prior_best_of=3
    all_lengths from_scratch_mixed n64_rho95_best3
    ;;
  horizon_n64)  # the committed n64_more (step 28000) continued to step 30400 at nice -n 10, the same learning-rate
    # profile, with the posterior shown the frame 16 steps ahead instead of the next one (model.posterior_horizon;
    # the control is best_of_n64's n64_cont); then every length. A run at k = 8 went beside it and beside
    # scratch_mixed_none, and was stopped at step 29225 (its training curves were the control's)
    nice -n 10 bin/train --config lafan1_cpu $CPU_BEFORE_PAPER --data "$DATA" --no-progress \
      --init-from $OUT/from_scratch_mixed/models/n64_more --max-steps 30400 --workdir runs/n64_h16 $(fine_tune_lr 28000 30400) $RECIPE loss.near_keyframe_frames=2 \
      loss.near_keyframe_weight=64 model.posterior_horizon=16
    all_lengths from_scratch_mixed n64_h16
    ;;
  evaluate_none_pair)  # the like-for-like pair, scratch_mixed (posterior) and scratch_mixed_none, sampled alike
    # (scratch_mixed_none trained again by the section scratch_mixed_none, at nice -n 10, its last checkpoint
    # copied to scratch_mixed/models/scratch_mixed_none):
    # every length at the paper's sampling (the retrained "none" against the first), then with the noise
    # correlated over frames (0.95) and ramped over 4 frames from each keyframe, at x1 and x2.5
    S=$OUT/scratch_mixed
    bin/evaluate model --checkpoint $S/models/scratch_mixed_none --data "$DATA" --samples 10 \
      --lengths 10,15,30,45,50 --noise-scales 0 --json $S/scratch_mixed_none_again_all_lengths.json
    for run in scratch_mixed scratch_mixed_none; do
      bin/evaluate model --checkpoint $S/models/$run --data "$DATA" --samples 10 --lengths 10,15,30,45,50 \
        --noise-scales 2.5 --noise-correlation 0.95 --noise-ramp 4 --json $S/${run}_rho95_ramp4_all_lengths.json
    done
    ;;
  frontier)  # diversity against quality at L = 50 (results/frontier.py): every sampling of the like-for-like pair
    # and of n64_more as a point, from the JSONs above
    S=$OUT/scratch_mixed; M=$OUT/from_scratch_mixed
    python results/frontier.py --length 50 --out $OUT/frontier_L50.png \
      "posterior (scratch_mixed), independent noise=$S/scratch_mixed_all_lengths.json+$S/scratch_mixed_noise_sweep_L50.json" \
      "none (scratch_mixed_none), independent noise=$S/scratch_mixed_none_all_lengths.json+$S/scratch_mixed_none_noise_sweep_L50.json" \
      "posterior (scratch_mixed), rho 0.95, ramp 4=$S/scratch_mixed_rho95_ramp4_all_lengths.json" \
      "none (scratch_mixed_none trained again), rho 0.95, ramp 4=$S/scratch_mixed_none_rho95_ramp4_all_lengths.json" \
      "n64_more, independent noise=$M/n64_more_all_lengths.json+$M/n64_more_noise_sweep_L50.json" \
      "n64_more, rho 0.95, ramp 4=$M/n64_more_rho95_ramp4_all_lengths.json"
    ;;
  prior25_n64)  # the committed n64_more (step 28000) continued to step 30400 with a quarter of every batch rolled
    # out from the prior instead of half (loss.prior_sample_fraction=0.25), the same learning-rate profile (the
    # control is best_of_n64's n64_cont); then every length, independent noise and correlated, ramped at x1 and x2.5
    nice -n 10 bin/train --config lafan1_cpu $CPU_BEFORE_PAPER --data "$DATA" --no-progress \
      --init-from $OUT/from_scratch_mixed/models/n64_more --max-steps 30400 --workdir runs/n64_prior25 \
      $(fine_tune_lr 28000 30400) $RECIPE loss.near_keyframe_frames=2 loss.near_keyframe_weight=64 \
      loss.prior_sample_fraction=0.25
    all_lengths from_scratch_mixed n64_prior25
    rho_ramp_all_lengths n64_prior25 n64_cont
    ;;
  n64_more_none)  # the like-for-like "none" of n64_more: scratch_mixed/models/scratch_mixed_none (step 16000) taken
    # through n64_more's five fine-tunes with model.posterior=none (sm_near8, sm_near32, n32_cont, n64, n64_more:
    # 2400 steps each, the same learning-rate profile, the weight near the keyframes 8, 32, 32, 64, 64), alone at
    # nice -n 5; then every length at the paper's sampling, and with the noise correlated and ramped at x1 and x2.5
    FROM=$OUT/scratch_mixed/models/scratch_mixed_none; STEP=16000
    for stage in 8:nn_near8 32:nn_near32 32:nn_n32 64:nn_n64 64:n64_more_none; do
      weight=${stage%%:*}; run=${stage#*:}
      nice -n 5 bin/train --config lafan1_cpu $CPU_BEFORE_PAPER --data "$DATA" --no-progress --init-from $FROM \
        --max-steps $((STEP + 2400)) --workdir runs/$run $(fine_tune_lr $STEP $((STEP + 2400))) $RECIPE \
        loss.near_keyframe_frames=2 loss.near_keyframe_weight=$weight model.posterior=none
      FROM=runs/$run; STEP=$((STEP + 2400))
    done
    all_lengths from_scratch_mixed n64_more_none
    rho_ramp_all_lengths n64_more_none
    ;;
  evaluate_n64_more_none)  # after n64_more_none: L = 50 at noise x2-x8 (as evaluate_n64_more for n64_more), and the
    # pair n64_more / n64_more_none on the diversity-quality frontier at L = 50
    M=$OUT/from_scratch_mixed
    bin/evaluate model --checkpoint runs/n64_more_none --data "$DATA" --samples 10 --lengths 50 \
      --noise-scales 2,3,4,6,8 --json $M/n64_more_none_noise_sweep_L50.json
    python results/frontier.py --length 50 --out $OUT/frontier_n64_L50.png \
      "posterior (n64_more), independent noise=$M/n64_more_all_lengths.json+$M/n64_more_noise_sweep_L50.json" \
      "none (n64_more_none), independent noise=$M/n64_more_none_all_lengths.json+$M/n64_more_none_noise_sweep_L50.json" \
      "posterior (n64_more), rho 0.95, ramp 4=$M/n64_more_rho95_ramp4_all_lengths.json" \
      "none (n64_more_none), rho 0.95, ramp 4=$M/n64_more_none_rho95_ramp4_all_lengths.json"
    ;;
  prior_kl_n64)  # the committed n64_more (step 28000) continued to step 30400 with the paper's KL(p || N(0, I)) on
    # the prior beside KL(q || p) (loss.prior_kl_weight 0.01 and 0.1; 105 nats per frame in n64_more), two side by side
    # at nice -n 5, the same learning-rate profile (the control is best_of_n64's n64_cont); then every length,
    # independent noise and correlated, ramped at x1 and x2.5
    for weight in 0.01 0.1; do
      nice -n 5 bin/train --config lafan1_cpu $CPU_BEFORE_PAPER --data "$DATA" --no-progress \
        --init-from $OUT/from_scratch_mixed/models/n64_more --max-steps 30400 --workdir runs/n64_pkl$weight \
        $(fine_tune_lr 28000 30400) $RECIPE loss.near_keyframe_frames=2 loss.near_keyframe_weight=64 \
        loss.prior_kl_weight=$weight &
    done
    wait
    all_lengths from_scratch_mixed n64_pkl0.01 n64_pkl0.1
    rho_ramp_all_lengths n64_pkl0.01 n64_pkl0.1
    ;;
  prior_kl_skate_n64)  # the prior's KL to N(0, I) at 0.02 with the foot-skate term at 256: n64_more (step 28000)
    # continued to step 30400 with both (n64_pkl0.02_s256), and the like-for-like "none" (n64_more_none continued
    # with the foot-skate weight at 256: prior_kl_weight is inert there); two side by side at nice -n 5, the same
    # learning-rate profile; then every length, independent noise and correlated, ramped at x1 and x2.5
    FT="--config lafan1_cpu $CPU_BEFORE_PAPER --data $DATA --no-progress --max-steps 30400 $(fine_tune_lr 28000 30400) $RECIPE"
    FT="$FT loss.near_keyframe_frames=2 loss.near_keyframe_weight=64"
    M=$OUT/from_scratch_mixed/models
    nice -n 5 bin/train $FT --init-from $M/n64_more --workdir runs/n64_pkl0.02_s256 loss.prior_kl_weight=0.02 \
      loss.foot_skate_weight=256 &
    nice -n 5 bin/train $FT --init-from $M/n64_more_none --workdir runs/nn_s256 model.posterior=none \
      loss.foot_skate_weight=256 &
    wait
    for run in n64_pkl0.02_s256 nn_s256; do
      all_lengths from_scratch_mixed $run
      rho_ramp_all_lengths $run
    done
    ;;
  prior_kl_skate_n64_more)  # the pair of prior_kl_skate_n64 continued to step 32800 with nothing changed, two
    # side by side at nice -n 5, the same learning-rate profile; then every length, independent noise and
    # correlated, ramped at x1 and x2.5
    FT="$(prior_kl_pair_fine_tune) loss.foot_skate_weight=256"
    nice -n 5 bin/train $FT --init-from runs/n64_pkl0.02_s256 --workdir runs/pks_more loss.prior_kl_weight=0.02 &
    nice -n 5 bin/train $FT --init-from runs/nn_s256 --workdir runs/nn_s256_more model.posterior=none &
    wait
    for run in pks_more nn_s256_more; do
      all_lengths from_scratch_mixed $run
      rho_ramp_all_lengths $run
    done
    ;;
  evaluate_prior_kl_skate)  # the committed pair of prior_kl_skate_n64 (step 30400; its 2400 more steps in
    # prior_kl_skate_n64_more were no better): L = 30 and 50 with the noise correlated and ramped at x1.25, x1.5
    # and x2; the pair on the frontier at L = 50; the filmstrip of n64_pkl0.02_s256 correlated and ramped at x1,
    # and the latent-space notebook on it
    M=$OUT/from_scratch_mixed
    SAMPLING="--noise-correlation 0.95 --noise-ramp 4"
    for run in n64_pkl0.02_s256 nn_s256; do
      bin/evaluate model --checkpoint $M/models/$run --data "$DATA" --samples 10 --lengths 30,50 \
        --noise-scales 1.25,1.5,2 $SAMPLING --json $M/${run}_rho95_ramp4_sweep.json
    done
    P=$M/n64_pkl0.02_s256; N=$M/nn_s256
    python results/frontier.py --length 50 --out $OUT/frontier_prior_kl_L50.png \
      "posterior (n64_pkl0.02_s256), independent noise=${P}_all_lengths.json" \
      "none (nn_s256), independent noise=${N}_all_lengths.json" \
      "posterior (n64_pkl0.02_s256), rho 0.95, ramp 4=${P}_rho95_ramp4_all_lengths.json+${P}_rho95_ramp4_sweep.json" \
      "none (nn_s256), rho 0.95, ramp 4=${N}_rho95_ramp4_all_lengths.json+${N}_rho95_ramp4_sweep.json"
    python results/figures.py --checkpoint $M/models/n64_pkl0.02_s256 --data "$DATA" --out $M/figures_prior_kl \
      --no-notebook $SAMPLING
    python results/figures.py --checkpoint $M/models/n64_pkl0.02_s256 --data "$DATA" --out $M/figures_prior_kl
    ;;
  foot_motion_prior_kl)  # why the committed pair's "none" slides its feet less at L = 45 and 50: how far the feet
    # and the root move, beside the foot slide (results/foot_motion.py), at L = 30 and 50, and at L = 50 along the
    # transition (foot_slide_along_L50.png)
    M=$OUT/from_scratch_mixed
    python results/foot_motion.py --data "$DATA" --length 30 --json $M/foot_motion_L30.json \
      posterior=$M/models/n64_pkl0.02_s256 none=$M/models/nn_s256
    python results/foot_motion.py --data "$DATA" --length 50 --json $M/foot_motion_L50.json \
      --plot $M/foot_slide_along_L50.png posterior=$M/models/n64_pkl0.02_s256 none=$M/models/nn_s256
    ;;
  skate512_prior_kl)  # the committed prior-KL pair (step 30400) continued to step 32800 with the foot-skate weight at
    # 512 (the controls are prior_kl_skate_n64_more's pks_more / nn_s256_more: the same steps at 256), two side by
    # side at nice -n 5, the same learning-rate profile; then every length, and the feet's motion at L = 50
    M=$OUT/from_scratch_mixed
    FT="$(prior_kl_pair_fine_tune) loss.foot_skate_weight=512"
    nice -n 5 bin/train $FT --init-from $M/models/n64_pkl0.02_s256 --workdir runs/pks512 loss.prior_kl_weight=0.02 &
    nice -n 5 bin/train $FT --init-from $M/models/nn_s256 --workdir runs/nn_s512 model.posterior=none &
    wait
    all_lengths from_scratch_mixed pks512 nn_s512
    python results/foot_motion.py --data "$DATA" --length 50 --json $M/foot_motion_skate512_L50.json \
      posterior=runs/pks512 none=runs/nn_s512
    ;;
  foot_velocity_prior_kl)  # foot_velocity_prior_kl WEIGHT: the committed prior-KL pair (step 30400) continued to
    # step 32800 with the foot velocity weight at WEIGHT instead of 16 (64, 128; the controls are
    # prior_kl_skate_n64_more's pks_more / nn_s256_more: the same steps at 16), two side by side at nice -n 5, the
    # same learning-rate profile; then every length, and the feet's motion at L = 50
    M=$OUT/from_scratch_mixed
    W=$2
    FT="$(prior_kl_pair_fine_tune) loss.foot_skate_weight=256"
    FT="$FT loss.foot_velocity_weight=$W"
    nice -n 5 bin/train $FT --init-from $M/models/n64_pkl0.02_s256 --workdir runs/pkv$W loss.prior_kl_weight=0.02 &
    nice -n 5 bin/train $FT --init-from $M/models/nn_s256 --workdir runs/nn_v$W model.posterior=none &
    wait
    all_lengths from_scratch_mixed pkv$W nn_v$W
    python results/foot_motion.py --data "$DATA" --length 50 --json $M/foot_motion_velocity${W}_L50.json \
      posterior=runs/pkv$W none=runs/nn_v$W
    ;;
  prior_fraction75_prior_kl)  # the committed posterior (step 30400) continued to step 32800 with
    # loss.prior_sample_fraction 0.75 instead of 0.5 (the field does nothing with "none", so the control is
    # prior_kl_skate_n64_more's nn_s256_more: the same steps with everything else the same); then every length, and
    # the feet's motion at L = 50
    M=$OUT/from_scratch_mixed
    FT="$(prior_kl_pair_fine_tune) loss.foot_skate_weight=256"
    nice -n 5 bin/train $FT --init-from $M/models/n64_pkl0.02_s256 --workdir runs/pkf75 loss.prior_kl_weight=0.02 \
      loss.prior_sample_fraction=0.75
    all_lengths from_scratch_mixed pkf75
    python results/foot_motion.py --data "$DATA" --length 50 --json $M/foot_motion_fraction75_L50.json \
      posterior=runs/pkf75 none=runs/nn_s256_more
    ;;
  prior_kl_velocity128)  # the prior's KL weight raised back up beside the foot velocity weight at 128: the
    # committed posterior (step 30400) continued to step 32800 as pkv128 of foot_velocity_prior_kl 128 but with
    # loss.prior_kl_weight 0.03 and 0.04 (the field does nothing with "none", so the control is nn_v128), two side
    # by side at nice -n 5; then every length
    M=$OUT/from_scratch_mixed
    FT="$(prior_kl_pair_fine_tune) loss.foot_skate_weight=256"
    FT="$FT loss.foot_velocity_weight=128"
    for weight in 0.03 0.04; do
      nice -n 5 bin/train $FT --init-from $M/models/n64_pkl0.02_s256 --workdir runs/pkv128_pkl$weight \
        loss.prior_kl_weight=$weight &
    done
    wait
    all_lengths from_scratch_mixed pkv128_pkl0.03 pkv128_pkl0.04
    ;;
  evaluate_velocity128)  # the pair of foot_velocity_prior_kl 128, committed as models/pkv128 and models/nn_v128
    # (step 32800, copied from runs/): every length correlated and ramped at x1 and x2.5 (two side by side); L = 30
    # and 50 correlated and ramped at x1.25, x1.5 and x2; the pair on the frontier at L = 50; the filmstrip of pkv128
    # correlated and ramped at x1, and the latent-space notebook on it
    M=$OUT/from_scratch_mixed
    SAMPLING="--noise-correlation 0.95 --noise-ramp 4"
    rho_ramp_all_lengths pkv128 & rho_ramp_all_lengths nn_v128 & wait
    for run in pkv128 nn_v128; do
      bin/evaluate model --checkpoint $M/models/$run --data "$DATA" --samples 10 --lengths 30,50 \
        --noise-scales 1.25,1.5,2 $SAMPLING --json $M/${run}_rho95_ramp4_sweep.json &
    done
    wait
    P=$M/pkv128; N=$M/nn_v128
    python results/frontier.py --length 50 --out $OUT/frontier_velocity128_L50.png \
      "posterior (pkv128), independent noise=${P}_all_lengths.json" \
      "none (nn_v128), independent noise=${N}_all_lengths.json" \
      "posterior (pkv128), rho 0.95, ramp 4=${P}_rho95_ramp4_all_lengths.json+${P}_rho95_ramp4_sweep.json" \
      "none (nn_v128), rho 0.95, ramp 4=${N}_rho95_ramp4_all_lengths.json+${N}_rho95_ramp4_sweep.json"
    python results/figures.py --checkpoint $M/models/pkv128 --data "$DATA" --out $M/figures_velocity128 \
      --no-notebook $SAMPLING
    python results/figures.py --checkpoint $M/models/pkv128 --data "$DATA" --out $M/figures_velocity128
    ;;
  search_velocity128)  # the committed pkv128 / nn_v128 at every length with the latent-pair search (4 candidate
    # pairs per sample), two side by side
    M=$OUT/from_scratch_mixed
    for run in pkv128 nn_v128; do
      bin/evaluate model --checkpoint $M/models/$run --data "$DATA" --samples 10 --lengths 10,15,30,45,50 \
        --search 4 --noise-scales "" --json $M/${run}_search4_all_lengths.json &
    done
    wait
    ;;
  velocity128_seed1)  # the pair of foot_velocity_prior_kl 128 trained again with train.seed=1 (which re-seeds
    # the key carried over from the committed pair: other batches and noise over the same 2400 steps), two side by
    # side at nice -n 5; then every length: how far a second seed moves the figures, the margins at L = 45 and 50
    # above all
    M=$OUT/from_scratch_mixed
    FT="$(prior_kl_pair_fine_tune) loss.foot_skate_weight=256"
    FT="$FT loss.foot_velocity_weight=128 train.seed=1"
    nice -n 5 bin/train $FT --init-from $M/models/n64_pkl0.02_s256 --workdir runs/pkv128_seed1 \
      loss.prior_kl_weight=0.02 &
    nice -n 5 bin/train $FT --init-from $M/models/nn_s256 --workdir runs/nn_v128_seed1 model.posterior=none &
    wait
    all_lengths from_scratch_mixed pkv128_seed1 nn_v128_seed1
    ;;
  evaluate_noise_correlation)  # the latent noise correlated from frame to frame at sampling only
    # (bin/evaluate --noise-correlation, results/noise_correlation.py): n64_more at every length with rho 0.95
    # and at L = 50 over rho; the scratch pair (height32, the posterior, and none) at L = 30 and 50; n64_cont
    # at every length with rho 0.95 (the control of rho95_n64, which trained with it)
    M=$OUT/from_scratch_mixed
    bin/evaluate model --checkpoint $M/models/n64_more --data "$DATA" --samples 10 --lengths 10,15,30,45,50 \
      --noise-scales 0 --noise-correlation 0.95 --json $M/n64_more_rho95_all_lengths.json
    python results/noise_correlation.py --checkpoint $M/models/n64_more --data "$DATA" --lengths 50 \
      --correlations 0,0.5,0.9,0.95,0.97,0.99,1 --json $M/n64_more_rho_sweep_L50.json
    for run in none height32; do
      python results/noise_correlation.py --checkpoint $OUT/scratch/models/$run --data "$DATA" --lengths 30,50 \
        --correlations 0,0.95 --json $OUT/scratch/${run}_rho.json
    done
    bin/evaluate model --checkpoint runs/n64_cont --data "$DATA" --samples 10 --lengths 10,15,30,45,50 \
      --noise-scales 0 --noise-correlation 0.95 --json $M/n64_cont_rho95_all_lengths.json
    python results/figures.py --checkpoint $M/models/n64_more --data "$DATA" --out $M/figures --no-notebook \
      --noise-correlation 0.95
    # with the noise also ramped up over 4 frames from each keyframe, at x1, x2 and x2.5; the scratch pair at x2.5
    SAMPLING="--noise-correlation 0.95 --noise-ramp 4"
    bin/evaluate model --checkpoint $M/models/n64_more --data "$DATA" --samples 10 --lengths 10,15,30,45,50 \
      --noise-scales 0,2,2.5 $SAMPLING --json $M/n64_more_rho95_ramp4_all_lengths.json
    for run in none height32; do
      bin/evaluate model --checkpoint $OUT/scratch/models/$run --data "$DATA" --samples 10 --lengths 30,50 \
        --noise-scales 2.5 $SAMPLING --json $OUT/scratch/${run}_rho95_ramp4.json
    done
    python results/figures.py --checkpoint $M/models/n64_more --data "$DATA" --out $M/figures --no-notebook \
      --noise-scale 2.5 $SAMPLING
    # the latent-space notebook on n64_more (its own sampling), then the same sampling as above with the
    # latent-pair search (4 pairs per sample), and with another sampling seed
    python results/figures.py --checkpoint $M/models/n64_more --data "$DATA" --out $M/figures
    bin/evaluate model --checkpoint $M/models/n64_more --data "$DATA" --samples 10 --lengths 30,50 \
      --noise-scales 2.5 $SAMPLING --search 4 --json $M/n64_more_rho95_ramp4_search4.json
    bin/evaluate model --checkpoint $M/models/n64_more --data "$DATA" --samples 10 --lengths 45,50 \
      --noise-scales 2.5 $SAMPLING --seed 1 --json $M/n64_more_rho95_ramp4_L45_50_seed1.json
    ;;
  evaluate_from_scratch_mixed)  # as evaluate_mixed_lengths, then every length
    evaluate_runs from_scratch_mixed sm_cont sm_fb4 sm_near8
    all_lengths from_scratch_mixed sm_cont sm_fb4 sm_near8
    ;;
  evaluate_scratch_mixed)  # as evaluate_mixed_lengths, then every length
    evaluate_runs scratch_mixed scratch_mixed
    all_lengths scratch_mixed scratch_mixed
    ;;
  evaluate_mixed_lengths)  # as evaluate_from_decay512
    evaluate_runs mixed_lengths mixed512 mixed_either512 mixed_either_fvel16
    ;;
  evaluate_from_decay512)  # L = 30 and 50 at noise x0, x1 and x1.5 for each run (the start, decay512, is
    # from_skate512/decay512.json), and where the error is along the transition (results/error_frames.py)
    evaluate_runs from_decay512 more512 keyvel512 fvel32
    for run in decay512 height32; do  # the same for the start and for the reproduction model (scratch/height32)
      python results/error_frames.py --checkpoint $OUT/*/models/$run --data "$DATA" --length 30 \
        --out $OUT/from_decay512/error_frames_$run
    done
    ;;
  train)  # the three runs went side by side on the same 2 cores (nice -n 10); see results/README.md
    bin/train --config lafan1_cpu $CPU_BEFORE_PAPER --workdir runs/cvae_noprior --data "$DATA" --no-progress $BEFORE  # the reproduction model
    bin/train --config lafan1_cpu $CPU_BEFORE_PAPER --workdir runs/none --data "$DATA" --no-progress $BEFORE model.posterior=none
    bin/train --config lafan1_cpu $CPU_BEFORE_PAPER --workdir runs/cvae --data "$DATA" --no-progress $BEFORE loss.prior_rollout=true
    ;;
  train_long)  # the reproduction run continued, a learning-rate decay, and two loss changes from step 5566
    # (results/README.md, "Longer training, a learning-rate decay, a foot-skate term"); runs/cvae_noprior
    # must hold its step-3000 checkpoint. Stopping and resuming gives the same state (tests/train/test_train.py).
    cp -r runs/cvae_noprior runs/cvae_long
    bin/train --config lafan1_cpu $CPU_BEFORE_PAPER --workdir runs/cvae_long --data "$DATA" --no-progress $BEFORE --max-steps 5566
    mkdir -p runs/base5566/checkpoints && cp -r runs/cvae_long/checkpoints/5566 runs/base5566/checkpoints/
    bin/train --config lafan1_cpu $CPU_BEFORE_PAPER --workdir runs/cvae_long --data "$DATA" --no-progress $BEFORE --max-steps 8372
    mkdir -p runs/cvae_8372/checkpoints && cp -r runs/cvae_long/checkpoints/8372 runs/cvae_8372/checkpoints/
    bin/train --config lafan1_cpu $CPU_BEFORE_PAPER --workdir runs/cvae_long --data "$DATA" --no-progress $BEFORE --max-steps "${LONG_STEPS:?}" \
      train.lr_decay_to=0.1 train.lr_decay_from_step=8372 train.lr_decay_until_step=10872
    bin/train --config lafan1_cpu $CPU_BEFORE_PAPER --workdir runs/kl05 --init-from runs/base5566 --data "$DATA" --no-progress $BEFORE \
      --max-steps 6536 loss.kl_weight=0.5
    bin/train --config lafan1_cpu $CPU_BEFORE_PAPER --workdir runs/footskate --init-from runs/base5566 --data "$DATA" --no-progress $BEFORE \
      --max-steps 7079 loss.foot_skate_weight=4
    mkdir -p runs/footskate_7079/checkpoints && cp -r runs/footskate/checkpoints/7079 runs/footskate_7079/checkpoints/
    bin/train --config lafan1_cpu $CPU_BEFORE_PAPER --workdir runs/footskate --data "$DATA" --no-progress $BEFORE --max-steps "${SKATE_STEPS:?}" \
      loss.foot_skate_weight=4 train.lr_decay_to=0.1 train.lr_decay_from_step=7079 train.lr_decay_until_step=9579
    ;;
  finetune)  # three fine-tunes of the reproduction model (runs/cvae_long, step 10930) side by side, 1500 steps
    # each at 0.3 x the learning rate: the control, prior samples in a quarter of each batch, the same with
    # the foot-skate term, then prior samples in half of each batch, with and without it (results/README.md,
    # "Prior samples at training"); at nice -n 10, two or three at a time, beside the evaluations
    FT="--config lafan1_cpu $CPU_BEFORE_PAPER --init-from runs/cvae_long --data $DATA --no-progress --max-steps ${FT_STEPS:-12430}"
    LR="$BEFORE train.lr_decay_to=0.3 train.lr_decay_from_step=10930 train.lr_decay_until_step=10931"
    bin/train $FT --workdir runs/ft_control $LR loss.prior_sample_fraction=0 &
    bin/train $FT --workdir runs/ft_prior25 $LR loss.prior_sample_fraction=0.25 &
    bin/train $FT --workdir runs/ft_prior25_skate8 $LR loss.prior_sample_fraction=0.25 loss.foot_skate_weight=8 &
    wait
    bin/train $FT --workdir runs/ft_prior50 $LR loss.prior_sample_fraction=0.5 &
    bin/train $FT --workdir runs/ft_prior50_skate8 $LR loss.prior_sample_fraction=0.5 loss.foot_skate_weight=8 &
    wait
    ;;
  evaluate_finetune)
    for run in ft_control ft_prior25 ft_prior25_skate8 ft_prior50; do
      bin/evaluate model --checkpoint runs/$run --data "$DATA" --samples 10 --lengths 30,50 --noise-scales 0 \
        --json $OUT/${run}.json
    done
    for run in ft_prior50 ft_prior50_skate8; do  # every length, noise x0 / x0.5, and the latent-pair search
      bin/evaluate model --checkpoint runs/$run --data "$DATA" --samples 10 --json $OUT/${run}_full.json
      bin/evaluate model --checkpoint runs/$run --data "$DATA" --samples 10 --search 4 --noise-scales "" \
        --json $OUT/${run}_full_search4.json
    done
    python results/figures.py --checkpoint runs/ft_prior50_skate8 --data "$DATA" --out $OUT/figures_ft_prior50_skate8
    python results/noise_correlation.py --checkpoint runs/cvae_long --data "$DATA" --json $OUT/noise_correlation.json
    python results/foot_slide_frames.py --checkpoint runs/cvae_long --data "$DATA" --length 30 \
      --out $OUT/foot_slide_frames
    ;;
  evaluate_long)
    bin/evaluate model --checkpoint runs/kl05/checkpoints/6250 --data "$DATA" --samples 10 --lengths 30,50 \
      --json $OUT/kl05_step6250.json
    bin/evaluate model --checkpoint runs/cvae_8372 --data "$DATA" --samples 10 --lengths 30,50 \
      --json $OUT/cvae_step8372.json
    for run in cvae_long footskate; do
      bin/evaluate model --checkpoint runs/$run --data "$DATA" --samples 10 --json $OUT/${run}_final.json
    done
    bin/evaluate model --checkpoint runs/cvae_long --data "$DATA" --samples 10 --search 4 --noise-scales "" \
      --json $OUT/cvae_long_final_search4.json
    ;;
  evaluate)
    for run in cvae_noprior none; do
      bin/evaluate model --checkpoint runs/$run --data "$DATA" --samples 10 --json $OUT/$run.json
      bin/evaluate model --checkpoint runs/$run --data "$DATA" --samples 10 --search 4 --noise-scales "" \
        --json $OUT/${run}_search4.json
    done
    bin/evaluate model --checkpoint runs/cvae --data "$DATA" --samples 10 --json $OUT/cvae.json
    python results/variance_blend.py --checkpoint runs/cvae_noprior --data "$DATA" --json $OUT/variance_blend.json
    ;;
  figures)
    python results/figures.py --checkpoint runs/cvae_long --data "$DATA" --out $OUT/figures
    python results/placed_target.py --checkpoint runs/cvae_long --data "$DATA" --length 50 --out $OUT/placed_target
    python results/cmu_contacts.py --data ../shared/data/cmu --workdir runs/cmu --out results/cmu
    ;;
  *) sed -n 's/^# Usage: /usage: /p; s/^#        /    /p' "$0" >&2  # the usage lines at the top
     exit 2 ;;
esac
