"""ResNet-18 in plain torch (He et al. 2016), the BC encoder of the paper's appendix.

torchvision cannot be used with this platform's CPU torch, so the network is written here with the
same layer names as torchvision's ``resnet18`` (``conv1``, ``bn1``, ``layer1.0.conv1``, ...): a
torchvision ImageNet ``state_dict`` saved elsewhere loads with ``load_pretrained``.
"""

from __future__ import annotations

from pathlib import Path

import torch
from torch import nn

from biovln_ms.errors import BioVLNError


class BasicBlock(nn.Module):
    def __init__(self, cin: int, cout: int, stride: int = 1) -> None:
        super().__init__()
        self.conv1 = nn.Conv2d(cin, cout, 3, stride, 1, bias=False)
        self.bn1 = nn.BatchNorm2d(cout)
        self.relu = nn.ReLU(inplace=True)
        self.conv2 = nn.Conv2d(cout, cout, 3, 1, 1, bias=False)
        self.bn2 = nn.BatchNorm2d(cout)
        self.downsample = None
        if stride != 1 or cin != cout:
            self.downsample = nn.Sequential(nn.Conv2d(cin, cout, 1, stride, bias=False), nn.BatchNorm2d(cout))

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        idt = x if self.downsample is None else self.downsample(x)
        y = self.relu(self.bn1(self.conv1(x)))
        return self.relu(self.bn2(self.conv2(y)) + idt)


class ResNet18(nn.Module):
    """Image (B, 3, H, W) -> 512-d global-average-pooled feature (no classifier head)."""

    feature_dim = 512

    def __init__(self) -> None:
        super().__init__()
        self.conv1 = nn.Conv2d(3, 64, 7, 2, 3, bias=False)
        self.bn1 = nn.BatchNorm2d(64)
        self.relu = nn.ReLU(inplace=True)
        self.maxpool = nn.MaxPool2d(3, 2, 1)
        widths = [64, 128, 256, 512]
        cin = 64
        for i, w in enumerate(widths):
            stride = 1 if i == 0 else 2
            setattr(self, f"layer{i + 1}", nn.Sequential(BasicBlock(cin, w, stride), BasicBlock(w, w)))
            cin = w
        self.avgpool = nn.AdaptiveAvgPool2d(1)
        for m in self.modules():
            if isinstance(m, nn.Conv2d):
                nn.init.kaiming_normal_(m.weight, mode="fan_out", nonlinearity="relu")

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        x = self.maxpool(self.relu(self.bn1(self.conv1(x))))
        x = self.layer4(self.layer3(self.layer2(self.layer1(x))))
        return torch.flatten(self.avgpool(x), 1)

    def load_pretrained(self, path: str | Path) -> list[str]:
        """Load a torchvision-layout ResNet-18 state dict (``fc.*`` ignored); returns missing keys."""

        try:
            state = torch.load(path, map_location="cpu", weights_only=True)
        except Exception as e:  # noqa: BLE001 - any unreadable file gets the same clear message
            raise BioVLNError(
                f"cannot read pretrained weights: {e}",
                source=str(path),
                field="pretrained",
                fix="pass a torch state_dict of torchvision's resnet18 saved with torch.save",
            ) from None
        state = {k: v for k, v in state.items() if not k.startswith("fc.")}
        result = self.load_state_dict(state, strict=False)
        if result.unexpected_keys or len(result.missing_keys) == len(self.state_dict()):
            raise BioVLNError(
                "these weights are not a ResNet-18",
                source=str(path),
                field="pretrained",
                fix="use torchvision resnet18 weights (conv1.weight, layer1.0.conv1.weight, ...)",
            )
        return list(result.missing_keys)
