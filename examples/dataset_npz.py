"""Load a dataset `roar dataset run.mcap --format npz --out run.npz` wrote, as a PyTorch Dataset
when PyTorch is installed (else as numpy batches): camera frames in, (angle, throttle) out.

    python examples/dataset_npz.py run.npz
"""

import sys

import numpy as np

data = np.load(sys.argv[1] if len(sys.argv) > 1 else "run.npz")
images, targets = data["images"], np.stack([data["angle"], data["throttle"]], axis=1)  # targets in [-1, 1]
print(f"{len(images)} frames of {images.shape[2]}x{images.shape[1]}, angle {targets[:, 0].min():+.2f}.."
      f"{targets[:, 0].max():+.2f}, over {data['t_s'][-1] - data['t_s'][0]:.1f} s")
try:
    import torch
    from torch.utils.data import DataLoader, TensorDataset

    frames = torch.from_numpy(images).permute(0, 3, 1, 2).float() / 255  # N, 3, H, W in [0, 1]
    loader = DataLoader(TensorDataset(frames, torch.from_numpy(targets)), batch_size=32, shuffle=True)
    x, y = next(iter(loader))
    print(f"a batch: images {tuple(x.shape)}, targets {tuple(y.shape)}")
except ImportError:  # no PyTorch: the same batches as arrays
    pick = np.random.default_rng(0).permutation(len(images))[:32]
    print(f"a batch (numpy; pip install torch for a DataLoader): images {images[pick].shape}, targets "
          f"{targets[pick].shape}")
