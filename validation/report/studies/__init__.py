"""The studies of ``demes validate`` beside its core comparison, one module each, each building
one :class:`validation.report.study.Study`."""
