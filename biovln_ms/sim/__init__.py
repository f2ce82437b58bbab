"""The simulator layer: scene specs built into SAPIEN scenes and ManiSkill scene builders. The pure model
(catalog, geometry, scene specs, episodes, measures) never imports it."""
