"""PyBullet adapters: robot body, joint servo, obstacle scene, ray sensor. Nothing else imports pybullet."""
