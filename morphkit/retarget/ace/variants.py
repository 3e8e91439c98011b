"""The retargeters of Table 1 (ACE and its ablations, and ACE+contact): each one's flags, set in one place."""

from __future__ import annotations

from dataclasses import replace
from enum import Enum

from morphkit.errors import ConfigError
from morphkit.retarget.ace.config import RetargetConfig

__all__ = ["CONTACT_WEIGHT", "AceVariant"]


CONTACT_WEIGHT = 2.0
"""``retarget.w_contact`` of ACE+contact where the config leaves it 0 (Table 1's ``--contact-weight`` default, measured
against 1 in docs/guides/evaluate.md)."""


class AceVariant(str, Enum):
    """A retargeter of Table 1: its trainer name (the value), stage folder, label and ablation flags.

    ``ACE_CONTACT`` is ACE with ``retarget.w_contact > 0`` (beyond the paper); every other variant trains with 0.
    """

    ACE = "ace"
    WO_FEA = "ace-wofea"
    WO_ADV = "ace-woadv"
    ACE_CONTACT = "ace-contact"

    @property
    def folder(self) -> str:
        """Its stage folder inside an ACE run."""
        return {"ace": "retarget", "ace-wofea": "retarget_wofea", "ace-woadv": "retarget_woadv",
                "ace-contact": "retarget_contact"}[self.value]

    @property
    def label(self) -> str:
        """Its name in Table 1."""
        labels = {"ace": "ACE", "ace-wofea": "ACEwoFea", "ace-woadv": "ACEwoAdv", "ace-contact": "ACE+contact"}
        return labels[self.value]

    @property
    def feature_loss(self) -> bool:
        """Whether it trains with the feature loss."""
        return self is not AceVariant.WO_FEA

    @property
    def adversarial(self) -> bool:
        """Whether it trains with the adversarial loss."""
        return self is not AceVariant.WO_ADV

    @property
    def contact(self) -> bool:
        """Whether it trains with G's contact term (``retarget.w_contact``)."""
        return self is AceVariant.ACE_CONTACT

    def configure(self, cfg: RetargetConfig) -> RetargetConfig:
        """``cfg`` with every flag of this variant, so its ``config.yaml`` records what was trained.

        ACE+contact keeps ``cfg.w_contact`` where it is > 0, else takes :data:`CONTACT_WEIGHT`.

        Raises:
            ConfigError: ``cfg`` turns off a loss this variant trains with (``--set retarget.adversarial=false``
                asks for ACEwoAdv, a variant of its own, and was silently trained as ACE), or turns on the
                contact term in a variant without it.
        """
        for flag, option in (("feature_loss", "--no-feature-loss"), ("adversarial", "--no-adversarial")):
            if getattr(self, flag) and not getattr(cfg, flag):
                other = AceVariant.of_flags(**{flag: False})
                raise ConfigError(f"retarget.{flag}=false is the {other.label} ablation, not {self.label}: train it "
                                  f"as its own variant ({option} in morphkit train ace, variant={other.value!r})")
        if cfg.w_contact < 0:
            raise ConfigError(f"retarget.w_contact must be >= 0, got {cfg.w_contact}")
        if cfg.w_contact > 0 and not self.contact:
            raise ConfigError(f"retarget.w_contact={cfg.w_contact} is {AceVariant.ACE_CONTACT.label}, not "
                              f"{self.label}: train it as its own variant (--contact-weight in morphkit train ace, "
                              f"variant={AceVariant.ACE_CONTACT.value!r})")
        w_contact = (cfg.w_contact or CONTACT_WEIGHT) if self.contact else 0.0
        # ACEwoFea's G is not chosen by the feature loss it ablates (it would borrow what it leaves out): its last epoch
        share = cfg.validation_share if self.feature_loss else 0.0
        return replace(cfg, feature_loss=self.feature_loss, adversarial=self.adversarial, w_contact=w_contact,
                       validation_share=share)

    @staticmethod
    def parse(name: str | AceVariant) -> AceVariant:
        """The variant of a trainer name, stage folder or Table-1 label.

        Raises:
            ConfigError: none of them.
        """
        if isinstance(name, AceVariant):
            return name
        for v in AceVariant:
            if name in (v.value, v.folder, v.label):
                return v
        raise ConfigError(f"unknown ACE variant {name!r}; expected one of: {', '.join(v.value for v in AceVariant)}")

    @staticmethod
    def of_flags(*, feature_loss: bool = True, adversarial: bool = True, contact_weight: float = 0.0) -> AceVariant:
        """The variant of a set of ablation flags (one ablation at a time).

        Raises:
            ConfigError: both losses off, or the contact term combined with an ablation.
        """
        if not feature_loss and not adversarial:
            raise ConfigError("--no-feature-loss and --no-adversarial together leave nothing to train")
        if contact_weight > 0 and not (feature_loss and adversarial):
            raise ConfigError("--contact-weight combines with full ACE only")
        if not feature_loss:
            return AceVariant.WO_FEA
        if not adversarial:
            return AceVariant.WO_ADV
        return AceVariant.ACE_CONTACT if contact_weight > 0 else AceVariant.ACE
